// Splitting, part files, merging and checkpoints. See parts.h.
#include "lensim/render/parts.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>

#include "lensim/io/exr_window.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"

namespace lensim::render {

std::pair<int, int> tileGrid(const PixelBounds& b, int count) {
  int best_nx = count, best_ny = 1;
  double best = 1e300;
  for (int nx = 1; nx <= count; ++nx) {
    if (count % nx) continue;
    const int ny = count / nx;
    const double aspect = (double(b.width()) / nx) / (double(b.height()) / ny);
    const double cost = std::abs(std::log(aspect));
    if (cost < best - 1e-12) best = cost, best_nx = nx, best_ny = ny;
  }
  return {best_nx, best_ny};
}

PixelBounds tileBounds(const PixelBounds& b, int index, int count) {
  if (count < 1 || index < 0 || index >= count)
    throw Error(fmt::format("tile {}/{}: expected 0 <= I < N", index, count));
  const auto [nx, ny] = tileGrid(b, count);
  if (nx > b.width() || ny > b.height())
    throw Error(fmt::format("tile {}/{}: {} tiles ({} x {}) do not fit in {} x {} pixels", index,
                            count, count, nx, ny, b.width(), b.height()));
  const int tx = index % nx, ty = index / nx;
  auto edge = [](int lo, int size, int k, int n) { return lo + int((long long)k * size / n); };
  return {edge(b.x0, b.width(), tx, nx), edge(b.x0, b.width(), tx + 1, nx),
          edge(b.y0, b.height(), ty, ny), edge(b.y0, b.height(), ty + 1, ny)};
}

namespace {

bool parseInt(const std::string& s, int& v) {
  if (s.empty() || s.size() > 9) return false;
  for (char c : s)
    if (c < '0' || c > '9') return false;
  v = std::stoi(s);
  return true;
}

}  // namespace

std::pair<int, int> parseTile(const std::string& t) {
  const size_t slash = t.find('/');
  int i = 0, n = 0;
  if (slash == std::string::npos || !parseInt(t.substr(0, slash), i) ||
      !parseInt(t.substr(slash + 1), n) || n < 1 || i >= n)
    throw Error(fmt::format("--tile \"{}\": expected I/N with 0 <= I < N (e.g. 3/16)", t));
  return {i, n};
}

std::pair<int, int> parseSppRange(const std::string& t) {
  const size_t colon = t.find(':');
  int a = 0, b = 0;
  if (colon == std::string::npos || !parseInt(t.substr(0, colon), a) ||
      !parseInt(t.substr(colon + 1), b) || a >= b)
    throw Error(fmt::format("--spp-range \"{}\": expected A:B with 0 <= A < B (e.g. 0:64)", t));
  return {a, b};
}

double parseDuration(const std::string& t) {
  size_t pos = 0;
  double v = 0;
  try {
    v = std::stod(t, &pos);
  } catch (const std::exception&) {
    pos = 0;
  }
  const std::string unit = pos ? t.substr(pos) : "";
  double scale = 0;
  if (pos && (unit.empty() || unit == "s")) scale = 1;
  if (unit == "ms") scale = 1e-3;
  if (unit == "m" || unit == "min") scale = 60;
  if (unit == "h") scale = 3600;
  if (scale == 0 || !(v > 0) || !std::isfinite(v))
    throw Error(fmt::format(
        "duration \"{}\": expected a positive number with an optional unit ms, s, m or h "
        "(e.g. 60s)",
        t));
  return v * scale;
}

std::string hashHex(const std::string& bytes) {
  uint64_t h = 0xcbf29ce484222325ULL;
  for (unsigned char c : bytes) {
    h ^= c;
    h *= 0x100000001b3ULL;
  }
  return fmt::format("{:016x}", h);
}

namespace {

std::string readAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "<unreadable " + path + ">";
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::string boundsText(const PixelBounds& b) {
  return fmt::format("{} {} {} {}", b.x0, b.x1, b.y0, b.y1);
}

std::string pixelsText(const PixelBounds& b) {
  return fmt::format("[{}, {}) x [{}, {})", b.x0, b.x1, b.y0, b.y1);
}

}  // namespace

std::map<std::string, std::string> renderIdentity(const scene::Scene& s, const RenderOptions& o,
                                                  const RenderPlan& plan,
                                                  const std::string& version) {
  // Every scene file read, in a fixed order.
  std::set<std::string> files{s.path};
  for (const auto* loc :
       {&s.camera.loc, &s.film.loc, &s.sampler.loc, &s.filter.loc, &s.integrator.loc})
    if (loc->valid()) files.insert(loc->file);
  for (const auto& x : s.shapes)
    if (x.loc.valid()) files.insert(x.loc.file);
  for (const auto& x : s.materials)
    if (x.loc.valid()) files.insert(x.loc.file);
  for (const auto& x : s.textures)
    if (x.loc.valid()) files.insert(x.loc.file);
  for (const auto& x : s.lights)
    if (x.loc.valid()) files.insert(x.loc.file);
  std::string lens_file;
  double film_distance = 0;
  if (s.camera.realistic) {
    lens_file = s.camera.realistic->lens_file;
    film_distance = s.camera.realistic->film_distance_mm.value_or(0);
  } else if (s.camera.legacy_realistic) {
    lens_file = s.camera.legacy_realistic->lens_file;
    film_distance = s.camera.legacy_realistic->film_distance_mm;
  }
  std::string text;
  for (const std::string& f : files) text += f + '\n' + readAll(f) + '\n';
  const std::string lens_text = lens_file.empty() ? "" : readAll(lens_file);
  text += lens_text;
  text += fmt::format("filmdistance {:a} quirks {}", film_distance, o.pbrt_v2_quirks);

  std::map<std::string, std::string> md;
  md["lensim:part"] = "1";
  md["lensim:scene"] = s.path;
  md["lensim:scene_hash"] = hashHex(text);
  md["lensim:seed"] = std::to_string(plan.seed);
  md["lensim:spp_total"] = std::to_string(plan.spp);
  md["lensim:spp_range"] = fmt::format("{}:{}", plan.spp_begin, plan.spp_end);
  md["lensim:tile"] = o.tile ? fmt::format("{}/{}", o.tile->first, o.tile->second) : "0/1";
  md["lensim:resolution"] = fmt::format("{} {}", s.film.x_resolution, s.film.y_resolution);
  md["lensim:pixelbounds"] = boundsText(plan.full_bounds);
  md["lensim:lens"] = lens_file.empty() ? "none" : lens_file + " " + hashHex(lens_text);
  md["lensim:version"] = version;
  return md;
}

// ---------------------------------------------------------------------------------------------

namespace {

constexpr const char* kSumNames[4] = {"R", "G", "B", "W"};

std::string sumChannel(int c, int word) {
  return fmt::format("sum.{}.{}", kSumNames[c], word);
}

std::string ghostSumChannel(int c, int word) {
  return fmt::format("ghost.sum.{}.{}", kSumNames[c], word);
}

/// The 32-bit word `word` of v's two's-complement bits.
uint32_t sumWord(Int128 v, int word) {
  return uint32_t(static_cast<unsigned __int128>(v) >> (32 * word));
}

/// v with word `word` of its bits or-ed in.
void orSumWord(Int128& v, uint32_t bits, int word) {
  v = Int128(static_cast<unsigned __int128>(v) |
             (static_cast<unsigned __int128>(bits) << (32 * word)));
}

Int128& component(PixelSum& p, int c) {
  return c < 3 ? p.rgb[c] : p.weight;
}

[[noreturn]] void partError(const std::string& path, const std::string& what) {
  throw Error(FileLoc{path}, what);
}

}  // namespace

void writePart(const std::string& path, const Part& part) {
  const size_t n = size_t(part.bounds.area());
  if (part.sums.size() != n) partError(path, "part sums do not match its pixel bounds");
  io::ExrWindowFile f;
  f.display_width = part.x_res, f.display_height = part.y_res;
  f.x0 = part.bounds.x0, f.y0 = part.bounds.y0;
  f.width = part.bounds.width(), f.height = part.bounds.height();
  f.metadata = part.metadata;
  const bool ghost = !part.ghost_sums.empty();
  if (ghost && part.ghost_sums.size() != n)
    partError(path, "part ghost sums do not match its pixel bounds");
  const io::Image im = sumsImage(part.bounds, part.sums, part.ghost_sums);
  for (int c = 0; c < im.channelCount(); ++c) {
    auto& v = f.float_channels[im.channels[size_t(c)]];
    v.resize(n);
    for (size_t i = 0; i < n; ++i) v[i] = im.pixels[size_t(im.channelCount()) * i + size_t(c)];
  }
  for (int c = 0; c < 4; ++c)
    for (int word = 0; word < 4; ++word) {
      auto& v = f.uint_channels[sumChannel(c, word)];
      v.resize(n);
      for (size_t i = 0; i < n; ++i) {
        PixelSum p = part.sums[i];
        v[i] = sumWord(component(p, c), word);
      }
    }
  for (int c = 0; ghost && c < 3; ++c)
    for (int word = 0; word < 4; ++word) {
      auto& v = f.uint_channels[ghostSumChannel(c, word)];
      v.resize(n);
      for (size_t i = 0; i < n; ++i) v[i] = sumWord(part.ghost_sums[i][size_t(c)], word);
    }
  if (!part.tile_done.empty()) {
    std::string done(part.tile_done.size(), '0');
    for (size_t t = 0; t < done.size(); ++t)
      if (part.tile_done[t]) done[t] = '1';
    f.metadata["lensim:checkpoint_tiles"] = done;
  }
  io::writeExrWindow(path, f);
}

Part readPart(const std::string& path) {
  io::ExrWindowFile f = io::readExrWindow(path);
  if (f.metadata.count("lensim:part") == 0)
    partError(path,
              "not a lensim part: it has no exact sums (render parts with --tile, --spp-range or "
              "--part)");
  Part p;
  p.path = path;
  p.metadata = f.metadata;
  p.x_res = f.display_width, p.y_res = f.display_height;
  p.bounds = {f.x0, f.x0 + f.width, f.y0, f.y0 + f.height};
  const size_t n = size_t(p.bounds.area());
  p.sums.assign(n, PixelSum{});
  for (int c = 0; c < 4; ++c)
    for (int word = 0; word < 4; ++word) {
      auto it = f.uint_channels.find(sumChannel(c, word));
      if (it == f.uint_channels.end())
        partError(path, fmt::format("part is missing its channel {}", sumChannel(c, word)));
      for (size_t i = 0; i < n; ++i) orSumWord(component(p.sums[i], c), it->second[i], word);
    }
  // The ghost layer (lens flare): all of its channels or none.
  int ghost_channels = 0;
  for (int c = 0; c < 3; ++c)
    for (int word = 0; word < 4; ++word)
      ghost_channels += int(f.uint_channels.count(ghostSumChannel(c, word)));
  if (ghost_channels != 0 && ghost_channels != 12)
    partError(path, fmt::format("part has {} of the 12 ghost-layer channels ghost.sum.*; expected "
                                "all of them (a lens-flare render) or none",
                                ghost_channels));
  if (ghost_channels == 12) {
    p.ghost_sums.assign(n, GhostSum{});
    for (int c = 0; c < 3; ++c)
      for (int word = 0; word < 4; ++word) {
        const auto& bits = f.uint_channels.at(ghostSumChannel(c, word));
        for (size_t i = 0; i < n; ++i) orSumWord(p.ghost_sums[i][size_t(c)], bits[i], word);
      }
  }
  if (auto it = f.metadata.find("lensim:checkpoint_tiles"); it != f.metadata.end()) {
    p.tile_done.resize(it->second.size());
    for (size_t t = 0; t < it->second.size(); ++t) p.tile_done[t] = it->second[t] == '1';
    p.metadata.erase("lensim:checkpoint_tiles");
  }
  return p;
}

io::Image sumsImage(const PixelBounds& b, const std::vector<PixelSum>& sums,
                    const std::vector<GhostSum>& ghost_sums) {
  std::vector<std::string> channels = {"R", "G", "B"};
  const bool ghost = !ghost_sums.empty();
  if (ghost)
    for (const std::string& c : Film::ghostChannels()) channels.push_back(c);
  io::Image im(b.width(), b.height(), std::move(channels));
  const size_t nc = size_t(im.channelCount());
  for (size_t i = 0; i < sums.size() && i < size_t(b.area()); ++i) {
    const auto v = Film::pixelValue(sums[i]);
    for (int c = 0; c < 3; ++c) im.pixels[nc * i + size_t(c)] = v[c];
    if (ghost && i < ghost_sums.size()) {
      const auto g = Film::ghostValue(sums[i], ghost_sums[i]);
      for (int c = 0; c < 3; ++c) im.pixels[nc * i + 3 + size_t(c)] = g[c];
    }
  }
  return im;
}

// ---------------------------------------------------------------------------------------------

namespace {

struct Range {
  int begin = 0, end = 0;
};

Range sppRange(const Part& p) {
  auto it = p.metadata.find("lensim:spp_range");
  if (it == p.metadata.end()) partError(p.path, "part has no lensim:spp_range");
  try {
    const auto r = parseSppRange(it->second);
    return {r.first, r.second};
  } catch (const Error&) {
    partError(p.path, fmt::format("bad lensim:spp_range \"{}\"", it->second));
  }
}

std::string meta(const Part& p, const std::string& key) {
  auto it = p.metadata.find(key);
  return it == p.metadata.end() ? std::string("(none)") : it->second;
}

}  // namespace

Part mergeParts(const std::vector<Part>& parts, bool allow_partial_samples) {
  if (parts.empty()) throw Error("merge: no parts given");
  const Part& first = parts[0];
  // Same render.
  const std::pair<const char*, const char*> identity[] = {
      {"lensim:scene_hash", "scenes (scene hash)"},
      {"lensim:seed", "seeds"},
      {"lensim:spp_total", "samples per pixel"},
      {"lensim:resolution", "resolutions"},
      {"lensim:pixelbounds", "pixel bounds (crop windows)"},
      {"lensim:lens", "lenses"},
      {"lensim:version", "lensim versions"},
  };
  for (const Part& p : parts) {
    for (const auto& [key, what] : identity)
      if (meta(p, key) != meta(first, key))
        partError(p.path,
                  fmt::format("cannot merge parts of different {}: {} has {} \"{}\", {} "
                              "has \"{}\"",
                              what, first.path, key, meta(first, key), p.path, meta(p, key)));
    if (p.metadata.count("lensim:partial") ||
        (!p.tile_done.empty() && std::count(p.tile_done.begin(), p.tile_done.end(), 0) > 0))
      partError(p.path,
                "part is unfinished (an interrupted render or a checkpoint); finish it with "
                "lensim render --resume");
  }
  int total = 0;
  try {
    total = std::stoi(meta(first, "lensim:spp_total"));
  } catch (const std::exception&) {
    partError(first.path, "bad lensim:spp_total");
  }
  PixelBounds full;
  if (std::sscanf(meta(first, "lensim:pixelbounds").c_str(), "%d %d %d %d", &full.x0, &full.x1,
                  &full.y0, &full.y1) != 4 ||
      full.width() <= 0 || full.height() <= 0)
    partError(first.path, "bad lensim:pixelbounds");
  std::vector<Range> ranges;
  for (const Part& p : parts) {
    ranges.push_back(sppRange(p));
    if (ranges.back().end > total)
      partError(p.path, fmt::format("spp range {}:{} exceeds the {} samples per pixel",
                                    ranges.back().begin, ranges.back().end, total));
    const PixelBounds& b = p.bounds;
    if (b.x0 < full.x0 || b.x1 > full.x1 || b.y0 < full.y0 || b.y1 > full.y1)
      partError(p.path, fmt::format("part pixels {} lie outside the render's pixel bounds {}",
                                    pixelsText(b), pixelsText(full)));
    if (p.sums.size() != size_t(b.area())) partError(p.path, "part sums do not match its size");
    if (p.ghost_sums.empty() != first.ghost_sums.empty())
      partError(p.path, fmt::format("cannot merge a part with lens flare's ghost layer and one "
                                    "without: {} has {}, {} has {}",
                                    first.path, first.ghost_sums.empty() ? "none" : "one", p.path,
                                    p.ghost_sums.empty() ? "none" : "one"));
    if (!p.ghost_sums.empty() && p.ghost_sums.size() != size_t(b.area()))
      partError(p.path, "part ghost sums do not match its size");
  }
  // Coverage: cut the bounds at every part edge; each cell must have sample ranges that tile
  // [0, total) exactly.
  std::vector<int> xs{full.x0, full.x1}, ys{full.y0, full.y1};
  for (const Part& p : parts) {
    xs.push_back(p.bounds.x0), xs.push_back(p.bounds.x1);
    ys.push_back(p.bounds.y0), ys.push_back(p.bounds.y1);
  }
  std::sort(xs.begin(), xs.end()), xs.erase(std::unique(xs.begin(), xs.end()), xs.end());
  std::sort(ys.begin(), ys.end()), ys.erase(std::unique(ys.begin(), ys.end()), ys.end());
  auto covering = [&](const PixelBounds& cell) {
    std::vector<size_t> cover;
    for (size_t k = 0; k < parts.size(); ++k) {
      const PixelBounds& b = parts[k].bounds;
      if (b.x0 <= cell.x0 && cell.x1 <= b.x1 && b.y0 <= cell.y0 && cell.y1 <= b.y1)
        cover.push_back(k);
    }
    return cover;
  };
  Range common;  // the samples every pixel has
  PixelBounds common_cell;
  // Missing tiles first, then the samples of each cell.
  for (size_t j = 0; j + 1 < ys.size(); ++j)
    for (size_t i = 0; i + 1 < xs.size(); ++i) {
      const PixelBounds cell{xs[i], xs[i + 1], ys[j], ys[j + 1]};
      if (covering(cell).empty())
        throw Error(
            fmt::format("merge: missing tile: no part covers pixels {} of the render "
                        "({} parts given)",
                        pixelsText(cell), parts.size()));
    }
  for (size_t j = 0; j + 1 < ys.size(); ++j)
    for (size_t i = 0; i + 1 < xs.size(); ++i) {
      const PixelBounds cell{xs[i], xs[i + 1], ys[j], ys[j + 1]};
      std::vector<size_t> cover = covering(cell);
      std::sort(cover.begin(), cover.end(), [&](size_t a, size_t b) {
        return ranges[a].begin < ranges[b].begin ||
               (ranges[a].begin == ranges[b].begin && ranges[a].end < ranges[b].end);
      });
      int at = allow_partial_samples ? ranges[cover[0]].begin : 0;
      const int lo = at;
      for (size_t k = 0; k < cover.size(); ++k) {
        const Range& r = ranges[cover[k]];
        if (r.begin < at)
          throw Error(fmt::format(
              "merge: overlapping parts: {} (samples {}:{}) and {} (samples "
              "{}:{}) both cover pixels {}",
              parts[cover[k - 1]].path, ranges[cover[k - 1]].begin, ranges[cover[k - 1]].end,
              parts[cover[k]].path, r.begin, r.end, pixelsText(cell)));
        if (r.begin > at)
          throw Error(fmt::format("merge: missing samples {}:{} of pixels {} (no part has them)",
                                  at, r.begin, pixelsText(cell)));
        at = r.end;
      }
      if (at < total && !allow_partial_samples)
        throw Error(fmt::format("merge: missing samples {}:{} of pixels {} (no part has them)", at,
                                total, pixelsText(cell)));
      // With partial samples, every pixel must still have the same ones.
      if (common.end == 0) {
        common = {lo, at}, common_cell = cell;
      } else if (common.begin != lo || common.end != at) {
        throw Error(fmt::format(
            "merge: the parts give pixels {} samples {}:{} but pixels {} "
            "samples {}:{}; every pixel needs the same samples",
            pixelsText(common_cell), common.begin, common.end, pixelsText(cell), lo, at));
      }
    }
  // The exact sum.
  Part out;
  out.metadata = first.metadata;
  out.metadata["lensim:spp_range"] = fmt::format("{}:{}", common.begin, common.end);
  out.metadata["lensim:tile"] = "0/1";
  out.metadata["lensim:spp"] = std::to_string(common.end - common.begin);
  out.metadata.erase("lensim:partial");
  out.x_res = first.x_res, out.y_res = first.y_res;
  out.bounds = full;
  out.sums.assign(size_t(full.area()), PixelSum{});
  const bool ghost = !first.ghost_sums.empty();
  if (ghost) out.ghost_sums.assign(size_t(full.area()), GhostSum{});
  for (const Part& p : parts)
    for (int y = p.bounds.y0; y < p.bounds.y1; ++y)
      for (int x = p.bounds.x0; x < p.bounds.x1; ++x) {
        const size_t o = size_t(y - full.y0) * size_t(full.width()) + size_t(x - full.x0);
        const size_t i =
            size_t(y - p.bounds.y0) * size_t(p.bounds.width()) + size_t(x - p.bounds.x0);
        out.sums[o] += p.sums[i];
        for (int c = 0; ghost && c < 3; ++c)
          out.ghost_sums[o][size_t(c)] += p.ghost_sums[i][size_t(c)];
      }
  return out;
}

}  // namespace lensim::render
