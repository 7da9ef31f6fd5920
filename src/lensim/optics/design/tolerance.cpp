#include "lensim/optics/design/tolerance.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>

#include "lensim/optics/design/image_quality.h"
#include "lensim/optics/design/placed_build.h"
#include "lensim/optics/glass.h"

namespace lensim::optics::design {

namespace {

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// A uniform double in [0, 1) from the generator's top 53 bits.
double unit(std::mt19937_64& g) { return static_cast<double>(g() >> 11) * 0x1.0p-53; }

// Percentile by linear interpolation between order statistics.
double percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  const double pos = q * (v.size() - 1);
  const size_t i = static_cast<size_t>(pos);
  if (i + 1 >= v.size()) return v.back();
  return v[i] + (pos - i) * (v[i + 1] - v[i]);
}

// The spot quadratics summed over the job's fields and wavelengths (`sum`) and over the
// wavelengths of each field (`fields`), of a coaxial lens or (placed) a placed one.
struct SpotSums {
  SpotQuadratic sum;
  std::vector<SpotQuadratic> fields;
};

SpotSums spotSums(const DesignJob& job, const LensPrescription& p, bool placed) {
  SpotSums out;
  const double primary = job.wavelengths_nm.front();
  for (double f : job.fields_deg) {
    SpotQuadratic field;
    for (double w : job.wavelengths_nm) {
      const SpotQuadratic q = placed ? placedBeam(p, f, w, primary, job.rings).spot
                                     : spotQuadratic(p, f, w, primary, job.rings);
      out.sum.a += q.a, out.sum.b += q.b, out.sum.c += q.c;
      field.a += q.a, field.b += q.b, field.c += q.c;
    }
    out.fields.push_back(field);
  }
  return out;
}

// Where the on-axis chief ray (primary wavelength) meets the image surface moved by the
// compensator's shift dz (the best RMS-spot plane over the job's fields), or by none.
Vec2 boresightPoint(const DesignJob& job, const LensPrescription& p, const SpotQuadratic& sum) {
  const PlacedBeam b = placedBeam(p, 0, job.wavelengths_nm.front(), job.wavelengths_nm.front(), 1);
  const double dz = job.tolerance.back_focus_compensator && sum.c > 0 ? -sum.b / sum.c : 0;
  return b.chief + b.chief_slope * dz;
}

}  // namespace

bool placedTolerancing(const DesignJob& job) {
  if (job.tolerance.criterion == "boresight") return true;
  for (const Tolerance& t : job.tolerance.tolerances)
    if (t.moves()) return true;
  return false;
}

LensPrescription toleranceNominal(const DesignJob& job) {
  LensPrescription p = job.start;
  for (const Tolerance& t : job.tolerance.tolerances)
    if (t.kind == Tolerance::Kind::Index || t.kind == Tolerance::Kind::Abbe)
      p = applyTolerance(std::move(p), t, 0);
  if (placedTolerancing(job)) {
    // Marked at the first decentre or tilt (the boresight criterion alone: the job).
    FileLoc loc{job.path, 1, 1};
    for (const Tolerance& t : job.tolerance.tolerances)
      if (t.moves()) {
        loc = t.loc;
        break;
      }
    p = placeOnAxis(std::move(p), loc);
  }
  return p;
}

void applyIrregularity(LensSurface& s, double fringes, double test_wavelength_nm) {
  const double a = fringes * test_wavelength_nm * 1e-6 / 4;  // mm of sag at the rim, each half
  const double h = s.semiAperture_mm();
  const double c = s.radius_mm != 0 ? 1 / s.radius_mm : 0;
  if (s.shape.poly.size() < 5) s.shape.poly.resize(5, 0.0);
  s.shape.poly[4] += a / (h * h * h * h);
  if (!s.shape.radius_x_mm) {  // else a second irregularity on the surface: x stays as it is
    s.shape.radius_x_mm = s.radius_mm;  // 0: flat in x, as the nominal plane
    s.shape.conic_x = s.shape.conic;
  }
  const double cy = c + 2 * a / (h * h);
  s.radius_mm = cy != 0 ? 1 / cy : 0;
}

LensPrescription applyTolerance(LensPrescription p, const Tolerance& t, double value) {
  if (t.moves()) {
    p = placeOnAxis(std::move(p), t.loc);
    const double dx = t.kind == Tolerance::Kind::DecentreX ? value : 0;
    const double dy = t.kind == Tolerance::Kind::DecentreY ? value : 0;
    const double tx = t.kind == Tolerance::Kind::TiltX ? value : 0;
    const double ty = t.kind == Tolerance::Kind::TiltY ? value : 0;
    moveRows(p, t.surface, t.last_surface, dx, dy, tx, ty);
    return p;
  }
  LensSurface& s = p.surfaces[t.surface];
  switch (t.kind) {
    case Tolerance::Kind::Radius: s.radius_mm += value; break;
    case Tolerance::Kind::Irregularity: applyIrregularity(s, value, t.test_wavelength_nm); break;
    case Tolerance::Kind::Thickness:
      if (p.noncoaxial_loc)
        changeThickness(p, t.surface, value);
      else
        s.thickness_mm += value;
      break;
    case Tolerance::Kind::Index:
    case Tolerance::Kind::Abbe: {
      const Glass g = resolveGlass(s.glass, s.ior);
      double nd = g.n_d(), vd = g.v_d();
      (t.kind == Tolerance::Kind::Index ? nd : vd) += value;
      s.ior = nd;
      if (!std::isfinite(vd)) {
        // A medium without dispersion (a bare index): the build stays non-dispersive, with the
        // index moved. The job reader refuses Abbe tolerances on such a medium.
        s.glass = GlassSpec{};
        break;
      }
      s.glass.name.clear();
      s.glass.n_d = nd;
      s.glass.v_d = vd;
      break;
    }
    default: break;
  }
  return p;
}

CriterionReference criterionReference(const DesignJob& job) {
  CriterionReference ref;
  if (job.tolerance.criterion != "boresight") return ref;
  const LensPrescription nominal = toleranceNominal(job);
  // The field sums only place the compensated film; without the compensator they are unused.
  const SpotQuadratic sum =
      job.tolerance.back_focus_compensator ? spotSums(job, nominal, true).sum : SpotQuadratic{};
  ref.boresight = boresightPoint(job, nominal, sum);
  ref.has_boresight = true;
  return ref;
}

double toleranceCriterion(const DesignJob& job, const LensPrescription& p, double* film_shift_mm,
                          std::vector<double>* field_rms_mm) {
  return toleranceCriterion(job, p, criterionReference(job), film_shift_mm, field_rms_mm);
}

double toleranceCriterion(const DesignJob& job, const LensPrescription& p,
                          const CriterionReference& ref, double* film_shift_mm,
                          std::vector<double>* field_rms_mm) {
  if (film_shift_mm) *film_shift_mm = 0;
  if (field_rms_mm) field_rms_mm->clear();
  const std::string& c = job.tolerance.criterion;
  if (c != "rms_spot" && c != "boresight" && c != "mtf") {
    DesignJob one = job;
    Operand o;
    o.kind = c == "efl"         ? Operand::Kind::Efl
             : c == "f_number"  ? Operand::Kind::FNumber
             : c == "bfl"       ? Operand::Kind::Bfl
             : c == "total_track" ? Operand::Kind::TotalTrack
                                  : Operand::Kind::LongitudinalColor;
    one.operands = {o};
    return operandValues(one, p)[0];
  }
  // Mean over fields and wavelengths of the squared RMS radius, a quadratic in the film shift.
  const bool placed = p.noncoaxial_loc.has_value() || c == "boresight";
  const LensPrescription pl = placed ? placeOnAxis(p, FileLoc{job.path, 1, 1}) : LensPrescription{};
  const SpotSums sums = spotSums(job, placed ? pl : p, placed);
  const SpotQuadratic& sum = sums.sum;
  const double nw = static_cast<double>(job.wavelengths_nm.size());
  const double n = static_cast<double>(job.fields_deg.size()) * nw;
  double dz = 0;
  if (job.tolerance.back_focus_compensator && sum.c > 0) dz = -sum.b / sum.c;
  if (film_shift_mm) *film_shift_mm = dz;
  auto rms = [&](const SpotQuadratic& q, double count) {
    return std::sqrt(std::max(0.0, (q.a + 2 * q.b * dz + q.c * dz * dz) / count));
  };
  if (field_rms_mm)
    for (const SpotQuadratic& q : sums.fields) field_rms_mm->push_back(rms(q, nw));
  if (c == "mtf") {
    // On the compensated film (the smallest RMS spot's plane): the mean over fields and the
    // asked azimuths of the polychromatic MTF at the frequency.
    LensPrescription f = p;
    f.surfaces.back().thickness_mm += dz;
    const std::string& az = job.tolerance.mtf_azimuth;
    double total = 0;
    int count = 0;
    for (double field : job.fields_deg)
      for (bool sagittal : {false, true}) {
        if ((az == "tangential" && sagittal) || (az == "sagittal" && !sagittal)) continue;
        total += mtfAt(f, field, job.wavelengths_nm, job.wavelengths_nm.front(),
                       job.tolerance.mtf_frequency, sagittal);
        ++count;
      }
    return total / count;
  }
  if (c == "boresight") {
    // The on-axis image point on the compensated film against the nominal lens's on its own.
    const Vec2 a = boresightPoint(job, pl, sum);
    const Vec2 b = ref.has_boresight ? ref.boresight : criterionReference(job).boresight;
    return std::hypot(a.x - b.x, a.y - b.y);
  }
  return rms(sum, n);
}

double drawTolerance(const Tolerance& t, std::uint64_t seed, int build, int index) {
  std::mt19937_64 g(splitmix64(splitmix64(seed) ^ (static_cast<std::uint64_t>(build) << 20 |
                                                   static_cast<std::uint64_t>(index))));
  switch (t.distribution) {
    case Tolerance::Distribution::Uniform: return t.delta * (2 * unit(g) - 1);
    case Tolerance::Distribution::EndPoint: return unit(g) < 0.5 ? -t.delta : t.delta;
    case Tolerance::Distribution::Normal:
      for (;;) {  // Box-Muller, sigma = delta / 2, redrawn beyond +-delta
        const double u1 = 1 - unit(g), u2 = unit(g);
        const double z = std::sqrt(-2 * std::log(u1)) * std::cos(2 * std::numbers::pi * u2);
        if (std::abs(z) <= 2) return 0.5 * t.delta * z;
      }
  }
  return 0;
}

namespace {

// Build `build` of the Monte Carlo run: every tolerance at its drawn value, the irregularities
// last (they turn a surface into a biconic about its radius as built).
LensPrescription drawnBuild(const DesignJob& job, LensPrescription p, int build) {
  const auto& tols = job.tolerance.tolerances;
  for (bool irregular : {false, true})
    for (size_t i = 0; i < tols.size(); ++i)
      if ((tols[i].kind == Tolerance::Kind::Irregularity) == irregular)
        p = applyTolerance(std::move(p), tols[i],
                           drawTolerance(tols[i], job.tolerance.seed, build, static_cast<int>(i)));
  return p;
}

}  // namespace

LensPrescription asBuiltLens(const DesignJob& job, int build) {
  LensPrescription p = drawnBuild(job, toleranceNominal(job), build);
  double dz = 0;
  toleranceCriterion(job, p, &dz);
  if (p.noncoaxial_loc)
    shiftImage(p, dz);
  else
    p.surfaces.back().thickness_mm += dz;
  p.name = fmt::format("{} (as built {}, seed {})", job.start.name, build, job.tolerance.seed);
  return p;
}

ToleranceResult runTolerancing(const DesignJob& job) {
  ToleranceResult r;
  const LensPrescription nominal = toleranceNominal(job);
  const CriterionReference ref = criterionReference(job);  // once per run, read by every thread
  r.nominal = toleranceCriterion(job, nominal, ref, nullptr, &r.nominal_fields);
  const auto& tols = job.tolerance.tolerances;
  r.sensitivity.resize(tols.size());
  tbb::parallel_for(0, static_cast<int>(tols.size()), [&](int i) {
    SensitivityRow& row = r.sensitivity[i];
    row.label = tols[i].label();
    auto change = [&](double value) {
      try {
        return toleranceCriterion(job, applyTolerance(nominal, tols[i], value), ref, nullptr,
                                  value > 0 ? &row.fields_plus : &row.fields_minus) -
               r.nominal;
      } catch (const Error& e) {
        throw Error(tols[i].loc, fmt::format("the lens with {} at {:+g} cannot be evaluated: {}",
                                             row.label, value, e.message()));
      }
    };
    row.plus = change(tols[i].delta);
    row.minus = change(-tols[i].delta);
  });
  double s2 = 0;
  for (const SensitivityRow& row : r.sensitivity) {
    const double m = std::max(std::abs(row.plus), std::abs(row.minus));
    s2 += m * m;
  }
  r.rss_change = std::sqrt(s2);
  const int n = job.tolerance.monte_carlo;
  r.builds.assign(n, 0);
  tbb::parallel_for(0, n, [&](int k) {
    const LensPrescription p = drawnBuild(job, nominal, k);
    try {
      r.builds[k] = toleranceCriterion(job, p, ref);
    } catch (const Error& e) {
      // Leaving the build out would bias the statistics: refuse instead.
      throw Error(fmt::format("Monte Carlo build {} (seed {}) cannot be evaluated: {}", k,
                              job.tolerance.seed, e.message()));
    }
  });
  if (n > 0) {
    double m = 0;
    for (double v : r.builds) m += v;
    r.mean = m / n;
    double v2 = 0;
    for (double v : r.builds) v2 += (v - r.mean) * (v - r.mean);
    r.stddev = n > 1 ? std::sqrt(v2 / (n - 1)) : 0;
    r.p10 = percentile(r.builds, 0.1);
    r.p50 = percentile(r.builds, 0.5);
    r.p90 = percentile(r.builds, 0.9);
    // The worst build: the lowest MTF, else the largest value.
    r.worst = job.tolerance.criterion == "mtf" ? *std::min_element(r.builds.begin(), r.builds.end())
                                               : *std::max_element(r.builds.begin(), r.builds.end());
  }
  return r;
}

}  // namespace lensim::optics::design
