// Sensor parameters (sensor_config.h).
#include "lensim/scene/sensor_config.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <sstream>
#include <type_traits>

#include <fmt/format.h>

namespace lensim::scene {

int CfaPattern::channel(int x, int y) const {
  if (mono) return 0;
  const int cx = ((x % width) + width) % width, cy = ((y % height) + height) % height;
  return colors[size_t(cy * width + cx)];
}

bool CfaPattern::hasW() const {
  return !mono && std::find(colors.begin(), colors.end(), kW) != colors.end();
}

std::string CfaPattern::text() const {
  if (mono) return "mono";
  std::string s;
  for (int y = 0; y < height; ++y) {
    if (y > 0) s += '/';
    for (int x = 0; x < width; ++x) s += "RGBW"[colors[size_t(y * width + x)]];
  }
  return s;
}

bool CfaPattern::dngReadable() const {
  if (mono) return true;
  // dcraw and LibRaw read an X-Trans tile's colours as 0-2 only (fgetc & 3: W would be 2).
  if (width == 6 && height == 6) return !hasW();
  if (!((width == 1 || width == 2) && (height == 1 || height == 2 || height == 4 || height == 8)))
    return false;
  // With W a fourth colour (CFAPlaneColor R, G, B, W) dcraw relabels no greens: `filters` holds
  // the tile as it is.
  if (hasW()) return true;
  // dcraw (dcraw.c 9.28, identify() and main()) holds the tile as `filters`, 2 bits for each
  // of 8 rows x 2 columns, relabels some greens as a fourth colour (the bit operation below),
  // then moves those back to green only at every other row (from row FC(1,0) >> 1) and every
  // other column (from FC(row,1) & 1), zeroing what it visits: a relabelled green it does not
  // visit, or a green it does, decodes as 0.
  uint32_t f = 0;
  for (int i = 15; i >= 0; --i) f = f << 2 | uint32_t(channel(i & 1, i >> 1));
  f |= ((f >> 2 & 0x22222222u) | (f << 2 & 0x88888888u)) & f << 1;
  auto fc = [&](int r, int c) { return int(f >> ((((r << 1) & 14) + (c & 1)) << 1) & 3); };
  const int r0 = fc(1, 0) >> 1;
  for (int r = 0; r < 8; ++r)
    for (int c = 0; c < 2; ++c) {
      const bool copied = (r - r0) % 2 == 0 && c == (fc(r, 1) & 1);
      if ((fc(r, c) == 3 && !copied) || (fc(r, c) == 1 && copied)) return false;
    }
  return true;
}

CfaPattern parseCfa(const std::string& text, const FileLoc& loc) {
  CfaPattern p;
  if (text == "mono") {
    p.mono = true;
    p.width = p.height = 1;
    p.colors = {0};
    return p;
  }
  auto bad = [&](const std::string& why) {
    throw Error(loc, fmt::format("\"cfa\": \"{}\" {}; expected \"mono\" or the filters' letters "
                                 "R, G, B, W row by row, rows separated by '/' (\"RG/GB\") or a "
                                 "square tile (\"RGGB\"), at most 8x8",
                                 text, why));
  };
  std::vector<std::string> rows;
  if (text.find('/') != std::string::npos) {
    size_t i = 0;
    while (true) {
      const size_t j = text.find('/', i);
      rows.push_back(text.substr(i, j == std::string::npos ? std::string::npos : j - i));
      if (j == std::string::npos) break;
      i = j + 1;
    }
  } else {
    const size_t n = text.size();
    size_t side = 1;
    while (side * side < n) ++side;
    if (n == 0 || side * side != n)
      bad(fmt::format("has {} letters, not a square tile (use '/' between rows)", n));
    for (size_t r = 0; r < side; ++r) rows.push_back(text.substr(r * side, side));
  }
  p.height = int(rows.size());
  p.width = int(rows[0].size());
  if (p.width == 0) bad("has an empty row");
  if (p.width > 8 || p.height > 8) bad(fmt::format("is {}x{}", p.width, p.height));
  p.colors.clear();
  for (const std::string& r : rows) {
    if (int(r.size()) != p.width)
      bad(fmt::format("has rows of {} and {} letters", p.width, r.size()));
    for (char c : r) {
      const char* at = std::strchr("RGBW", c);
      if (c == 0 || !at) bad(fmt::format("has the letter '{}'", c));
      p.colors.push_back(uint8_t(at - "RGBW"));
    }
  }
  for (uint8_t c = 0; c < 3; ++c)
    if (std::find(p.colors.begin(), p.colors.end(), c) == p.colors.end())
      bad(fmt::format("has no {} filter", "RGB"[c]));
  return p;
}

void checkDngCfa(const CfaPattern& cfa, const FileLoc& loc, const std::string& dng_cfa) {
  if (!cfa.dngReadable() && dng_cfa != "bayer")
    throw Error(loc, fmt::format("\"cfa\": a DNG of the {}x{} pattern \"{}\" would be misread by "
                                 "dcraw, which holds a CFA as 8 rows of 2 columns with its "
                                 "second greens placed as in a Bayer pattern, or as a 6x6 "
                                 "X-Trans of R, G, B; expected such a tile (1 or 2 pixels wide, "
                                 "1, 2, 4 or 8 high), a 6x6 one without W, an .exr output, or "
                                 "\"string dngcfa\" \"bayer\" (the DNG remosaiced to RGGB)",
                                 cfa.width, cfa.height, cfa.text()));
}

namespace {
// Every field with its text name, for toText/fromText.
template <typename F>
void forEachField(SensorConfig& c, F&& f) {
  f("qe", c.qe);
  f("cfa", c.cfa);
  f("dngcfa", c.dng_cfa);
  f("peakqe", c.peak_qe);
  f("ircut", c.ircut_nm);
  f("ircutwidth", c.ircut_width_nm);
  f("pixelpitch", c.pixel_pitch_um);
  f("fillfactor", c.fill_factor);
  f("exposuretime", c.exposure_s);
  f("iso", c.iso);
  f("baseiso", c.base_iso);
  f("irradiancescale", c.irradiance_scale);
  f("temperature", c.temperature_c);
  f("darkcurrent", c.dark_current_e_s);
  f("darkreftemperature", c.dark_ref_c);
  f("darkdoubling", c.dark_doubling_c);
  f("readnoise", c.read_noise_e);
  f("dsnu", c.dsnu_e);
  f("prnu", c.prnu);
  f("fullwell", c.full_well_e);
  f("conversiongain", c.conversion_gain_e_dn);
  f("adcbits", c.adc_bits);
  f("blacklevel", c.black_level_dn);
  f("seed", c.seed);
  f("patternseed", c.pattern_seed);
  f("noise", c.noise);
}
}  // namespace

std::string SensorConfig::toText() const {
  std::string out;
  SensorConfig c = *this;
  forEachField(c, [&](const char* key, auto& v) {
    using T = std::decay_t<decltype(v)>;
    if constexpr (std::is_same_v<T, std::string>)
      out += fmt::format("{}={}\n", key, v);
    else if constexpr (std::is_same_v<T, double>)
      out += fmt::format("{}={:.17g}\n", key, v);
    else
      out += fmt::format("{}={}\n", key, v);
  });
  return out;
}

SensorConfig SensorConfig::fromText(const std::string& text) {
  std::map<std::string, std::string> kv;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    const size_t eq = line.find('=');
    if (eq != std::string::npos) kv[line.substr(0, eq)] = line.substr(eq + 1);
  }
  SensorConfig c;
  forEachField(c, [&](const char* key, auto& v) {
    auto it = kv.find(key);
    if (it == kv.end()) throw Error(fmt::format("sensor description: missing \"{}\"", key));
    using T = std::decay_t<decltype(v)>;
    try {
      if constexpr (std::is_same_v<T, std::string>)
        v = it->second;
      else if constexpr (std::is_same_v<T, double>)
        v = std::stod(it->second);
      else if constexpr (std::is_same_v<T, bool>)
        v = it->second == "true" || it->second == "1";
      else if constexpr (std::is_same_v<T, uint64_t>)
        v = std::stoull(it->second);
      else
        v = std::stoi(it->second);
    } catch (const std::exception&) {
      throw Error(fmt::format("sensor description: bad \"{}\" value \"{}\"", key, it->second));
    }
  });
  return c;
}

void SensorConfig::validate(const FileLoc& loc) const {
  auto need = [&](bool ok, const char* key, double v, const char* expected) {
    if (!ok) throw Error(loc, fmt::format("\"{}\": {} is out of range; expected {}", key, v,
                                          expected));
  };
  parseCfa(cfa, loc);
  if (dng_cfa != "native" && dng_cfa != "bayer")
    throw Error(loc, fmt::format("\"dngcfa\": \"{}\"; expected \"native\" or \"bayer\"", dng_cfa));
  need(peak_qe > 0 && peak_qe <= 1, "peakqe", peak_qe, "(0, 1]");
  need(ircut_nm == 0 || (ircut_nm >= 360 && ircut_nm <= 1100), "ircut", ircut_nm,
       "0 (none) or a wavelength in [360, 1100] nm");
  need(ircut_width_nm > 0 && ircut_width_nm <= 200, "ircutwidth", ircut_width_nm,
       "(0, 200] nm");
  need(pixel_pitch_um > 0 && pixel_pitch_um <= 1000, "pixelpitch", pixel_pitch_um,
       "(0, 1000] micrometres");
  need(fill_factor > 0 && fill_factor <= 1, "fillfactor", fill_factor, "(0, 1]");
  need(exposure_s > 0 && exposure_s <= 1e6, "exposuretime", exposure_s, "(0, 1e6] s");
  need(iso > 0 && iso <= 1e7, "iso", iso, "(0, 1e7]");
  need(base_iso > 0 && base_iso <= 1e7, "baseiso", base_iso, "(0, 1e7]");
  need(irradiance_scale > 0 && irradiance_scale < 1e30, "irradiancescale", irradiance_scale,
       "a positive number (W m^-2 nm^-1 per unit film value)");
  need(temperature_c >= -273.15 && temperature_c <= 500, "temperature", temperature_c,
       "[-273.15, 500] degrees C");
  need(dark_current_e_s >= 0 && dark_current_e_s <= 1e9, "darkcurrent", dark_current_e_s,
       "[0, 1e9] e-/s");
  need(dark_ref_c >= -273.15 && dark_ref_c <= 500, "darkreftemperature", dark_ref_c,
       "[-273.15, 500] degrees C");
  need(dark_doubling_c > 0 && dark_doubling_c <= 1000, "darkdoubling", dark_doubling_c,
       "(0, 1000] degrees C");
  need(read_noise_e >= 0 && read_noise_e <= 1e6, "readnoise", read_noise_e, "[0, 1e6] e-");
  need(dsnu_e >= 0 && dsnu_e <= 1e6, "dsnu", dsnu_e, "[0, 1e6] e-");
  need(prnu >= 0 && prnu <= 1, "prnu", prnu, "[0, 1]");
  need(full_well_e >= 1 && full_well_e <= 1e9, "fullwell", full_well_e, "[1, 1e9] e-");
  need(conversion_gain_e_dn > 0 && conversion_gain_e_dn <= 1e6, "conversiongain",
       conversion_gain_e_dn, "(0, 1e6] e-/DN");
  need(adc_bits >= 8 && adc_bits <= 16, "adcbits", adc_bits, "8 to 16");
  need(black_level_dn >= 0 && black_level_dn < (1 << adc_bits) - 1, "blacklevel",
       black_level_dn, "0 to 2^adcbits - 2");
}

double SensorConfig::darkCurrent() const {
  return dark_current_e_s * std::exp2((temperature_c - dark_ref_c) / dark_doubling_c);
}

double SensorConfig::gainDnPerE() const { return (iso / base_iso) / conversion_gain_e_dn; }

}  // namespace lensim::scene
