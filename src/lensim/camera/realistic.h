// The realistic camera: every camera ray traced through a real lens prescription (Kolb, Mitchell
// & Hanrahan 1995; pbrt's RealisticCamera), with lensim's exact tracer and exit-pupil bounds.
//
// Camera space is pbrt-v3/v4's: the film lies in the plane z = 0 and the lens in front of it along
// +z; lens space (optics/lens_system.h) maps to it by (x, y, z) -> (x, y, z_film - z), scaled from
// millimetres to camera units (metres for pbrt-v3/v4 scenes). The v1/v2 scenes of the CS348B
// assignment have camera space in millimetres with the origin at the lens's front vertex
// ((x, y, z) -> (x, y, -z)): the assignment's reference images match only that placement. A raster
// point at the right of the image lies at -x on the film, so that, after the lens inverts the
// image, a scene point on the camera's right appears on the image's right (as with pbrt's
// perspective camera).
//
// What the film stores: each ray's radiance times its weight
//   w = T x cos^4(theta) x A / z^2,
// the Monte Carlo estimate of the film irradiance integral E = L cos^4(theta) / z^2 dA over the
// sampled region of the rear-vertex plane (area A, at axial distance z from the film; theta is the
// angle of the film-side ray to the axis; T the aperture shape's transmission). The film then
// multiplies by its imaging ratio, exposure time x ISO / 100 (pbrt-v4's sensor; exposure time =
// shutterclose - shutteropen, taken as 1 when the scene gives none), so a pixel holds exposure
// H = E t in the units of L. Where a pinhole render of a surface of radiance L reads L, the
// realistic camera reads about L pi / (4 N^2) t at the image centre for working f-number N: a
// photographer's exposure. The v1/v2 scenes have no exposure time (their shutter is 0 to 0):
// their pixels hold irradiance, as the assignment's reference renderer did. Like that renderer,
// v1/v2 cameras aim rays only at the rear element's disc (see RealisticSettings::rear_disc_only)
// and put the camera origin at the front vertex (RealisticSettings::origin_at_front_vertex).
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "lensim/camera/aperture.h"
#include "lensim/camera/camera.h"
#include "lensim/camera/placed_pupil.h"
#include "lensim/optics/absorption.h"
#include "lensim/optics/focus.h"
#include "lensim/optics/pupil.h"
#include "lensim/optics/tilt_shift.h"
#include "lensim/scene/realistic_options.h"
#include "lensim/util/transform.h"

namespace lensim::camera {

/// Everything the realistic camera needs, resolved from a scene description: the options the
/// scene gives as they are (scene::RealisticOptions) and those resolved from the scene.
struct RealisticSettings : scene::RealisticOptions {
  std::string lens_path;
  /// The lens as already read from lens_path (makeRealisticCamera reads it to choose the
  /// camera); null: read lens_path.
  std::shared_ptr<const optics::LensPrescription> prescription;
  optics::LensSetup setup;       ///< stop diameter, focus or film distance, focus method
  double film_diagonal_mm = 35;  ///< sensor diagonal
  int x_resolution = 256, y_resolution = 256;
  double camera_units_per_mm = 0.001;  ///< 0.001: metres (v3/v4); 1: millimetres (v1/v2)
  /// World from camera space over the shutter (camera.h, worldFromCamera): the lens sits in
  /// camera space, so a moving camera moves only this transform.
  AnimatedTransform world_from_camera;
  double exposure_time = 1;  ///< seconds (the film applies it)
  /// The shutter (seconds): ray times are uniform over [shutter_open, shutter_close].
  double shutter_open = 0, shutter_close = 0;
  ApertureShape aperture = ApertureShape::round();
  /// Aim camera rays only at the disc of the rear element on its vertex plane, as the CS348B
  /// assignment's reference renderer did (set for v1/v2 scenes, whose reference images show the
  /// resulting darker corners). The complete region is sampled otherwise: rays that pass the
  /// curved rear surface through that plane outside the disc carry light too.
  bool rear_disc_only = false;
  /// Put the camera-space origin at the lens's front vertex (the film lies behind it, at
  /// z = -(lens length + film distance)), as the CS348B assignment's renderer did; set for v1/v2
  /// scenes. Otherwise the film is at the origin, as in pbrt-v3/v4.
  bool origin_at_front_vertex = false;
  /// pbrt-v2's differential rule (CameraOptions::pbrt_v2_quirks): a sample yields no ray when
  /// the ray from the film point one pixel to the right (+x raster) or one pixel down (+y
  /// raster), aimed at the same rear-plane point, is blocked by the lens.
  bool zero_if_neighbour_blocked = false;
  /// The pixel filter's radius (pixels): film points this far beyond the image's edge still
  /// reach its edge pixels (camera importance accepts them; film_bounds.h).
  Vec2 filter_radius{0.5, 0.5};
  /// An as-built lens (RealisticOptions::tolerance_job): keep the film where the build's
  /// back-focus compensator put it (no focusdistance or filmdistance given).
  bool as_built_film = false;
  /// Flare: draw each ghost pair's directions from its own bound (realistic_flare.cpp, "Per-ghost
  /// bounds") rather than the disc that holds every pair's. Off only to compare (tests, bench).
  bool flare_ghost_bounds = true;
  /// A tilted film: draw each film point's rays from its exit-pupil polygon (realistic.cpp, "Tilt
  /// and shift") where smaller than its disc. Off only to compare (tests, bench).
  bool tilt_pupil_bounds = true;
};

class RealisticCamera final : public Camera {
 public:
  /// Reads the lens, focuses it, opens the stop to the aperture shape and builds the pupil
  /// bounds. Throws lensim::Error for a bad lens file or settings the lens cannot meet.
  explicit RealisticCamera(RealisticSettings settings);

  std::optional<CameraRay> generateRay(const CameraSample& sample) const override;
  /// Traces the samples' rays through the lens side by side (LensTracer::traceFromFilmBatch);
  /// the same rays as generateRay.
  void generateRays(const CameraSample* samples, int n,
                    std::optional<CameraRay>* rays) const override;
  double startupSeconds() const override { return startup_seconds_; }
  double startupCpuSeconds() const override { return startup_cpu_seconds_; }
  bool reachesFilm(const CameraSample& sample) const override;
  std::string describe() const override;

  // Lens flare (realistic_flare.cpp).
  bool flare() const override { return flare_ != nullptr; }
  /// The light side's ghost connections use the lens's primary-wavelength indices: not for a
  /// dispersive lens, whose flare is traced at each sample's hero wavelength.
  bool flareInLightPaths() const override { return flare() && !dispersive_; }
  std::optional<CameraRay> generateGhostRay(const CameraSample& sample) const override;
  /// The ghost pairs the flare estimator chooses from (first reflection at `first`, then at
  /// `second` < first) and the probability of each; empty without flare.
  struct GhostChoice {
    int first = 0, second = 0;
    double probability = 0;
  };
  std::vector<GhostChoice> ghostChoices() const;
  /// The plane (lens z, mm) in which ghost directions are drawn, and whether ghost pair k
  /// (ghostChoices' order) draws them, from film point film_mm (lens space, mm), over a region
  /// of that plane that holds the point q_mm. For tests of the per-ghost bounds.
  double ghostPlaneZ_mm() const;
  bool ghostRegionHolds(int k, Vec2 film_mm, Vec2 q_mm) const;
  std::optional<CameraWiSample> sampleGhostWi(
      const Vec3& ref, const std::array<double, 3>& u,
      const std::array<double, kCameraWavelengths>& lambda_nm, double time) const override;

  // Camera importance (realistic_importance.cpp).
  /// Also for a tilted or shifted lens (film points on the placed film, the sampled region
  /// of placedFilmRay).
  bool supportsImportance() const override { return true; }
  std::optional<CameraWiSample> sampleWi(const Vec3& ref, Vec2 u,
                                         const std::array<double, kCameraWavelengths>& lambda_nm,
                                         double time) const override;
  double importance(const Vec3& o, const Vec3& d, double lambda_nm, Vec2* film_raster,
                    double time) const override;
  CameraRayPdf rayPdf(const Vec3& o, const Vec3& d, double lambda_nm, double time) const override;
  double pdfWiPos(const Vec3& ref, const Vec3& p_lens, double time) const override;

  /// The lens as set up (film position, stop, paraxial data).
  const optics::FocusedLens& lens() const { return lens_; }
  /// Film position in lens space (mm) of a raster position.
  Vec2 filmPoint(Vec2 raster) const;
  /// Area of the sampled rear-plane region at the film centre (simple weighting's A0), mm^2.
  double centreAreaMm2() const { return centre_area_mm2_; }
  /// The film's placement against the lens when tilted or shifted.
  const std::optional<optics::FilmPlacement>& placement() const { return placement_; }
  /// The plane of sharp focus of a tilted film (first-order, optics/tilt_shift.h).
  const std::optional<optics::ScheimpflugData>& scheimpflug() const { return scheimpflug_; }
  /// A tilted film: the region of the plane z = tiltPlaneZ_mm() (lens space) that the film
  /// point (film frame, mm) draws its rays from, and the bounds that give its polygon.
  PupilRegion tiltRegion(Vec2 film) const;
  double tiltPlaneZ_mm() const { return rear_zmax_mm_; }
  const PlacedPupilBounds& tiltPupilBounds() const { return tilt_bounds_; }
  /// Diagnostics from setting up the lens (e.g. an aperture clamped to the stop's size).
  std::vector<Diagnostic> diagnostics() const { return lens_.allDiagnostics(); }

 private:
  /// A sample's ray from the film toward its pupil point, before the lens.
  struct FilmRay {
    optics::RayT<float> ray;
    double cos_theta = 1;  ///< to the axis
    double area_mm2 = 0;   ///< of the sampled pupil region
    /// Tilted or shifted film: cos(at the film) cos(at the sampled plane) / distance^2 (1/mm^2),
    /// the geometric factor of the film irradiance integral.
    double g_per_mm2 = 0;
  };
  /// A tilted or shifted film's ray for a sample (see realistic.cpp, "Tilt and shift").
  std::optional<FilmRay> placedFilmRay(const CameraSample& sample, Vec2 film) const;
  /// The ray from the sample's film point toward its pupil point (ps: the pupil sample drawn
  /// for that film point).
  std::optional<FilmRay> filmRay(const CameraSample& sample, Vec2 film,
                                 const std::optional<optics::PupilSample>& ps) const;
  /// The camera ray from the lens's exit ray, weighted; nullopt if the aperture shape stops it.
  std::optional<CameraRay> finish(const optics::TraceResultT<float>& r, const FilmRay& f,
                                  double u_time) const;

  RealisticSettings settings_;
  optics::FocusedLens lens_;
  /// The exit-pupil bounds; for a dispersive lens one per wavelength band too (band k holds the
  /// regions of [band_edges_nm_[k], band_edges_nm_[k + 1]]).
  std::optional<optics::ExitPupilSampler> pupil_;
  static constexpr int kWavelengthBands = 6;
  std::vector<double> band_edges_nm_;
  /// The band of the wavelength; -1 (the lens's own bound) for a lens without bands or no
  /// wavelength.
  int bandAt(double lambda_nm) const;
  double half_width_mm_ = 0, half_height_mm_ = 0;
  double stop_radius_mm_ = 0;
  double centre_area_mm2_ = 0;  // sampled region at the film centre (simple weighting)  // the set
                                // stop radius: the aperture shape's unit
  double startup_seconds_ = 0, startup_cpu_seconds_ = 0;
  /// Tilt and shift: the film's placement (none: the film on the axis, untilted) and, for a
  /// tilt, the plane of focus and the sampled disc's plane (the rear surface's z extent and
  /// clear semi-aperture, lens space).
  std::optional<optics::FilmPlacement> placement_;
  std::optional<optics::ScheimpflugData> scheimpflug_;
  double rear_zmin_mm_ = 0, rear_zmax_mm_ = 0, rear_semi_mm_ = 0;
  void setUpTiltShift(const Vec2& sampled_half_extent_mm);
  /// A tilted film: the radius of the disc on the plane z = rear_zmax_mm_ that a film point
  /// (lens space) samples (realistic.cpp, "Tilt and shift").
  double tiltDiscRadius(const Vec3& film_point_lens_mm) const;
  /// A tilted film's exit-pupil polygons on that plane (empty without them).
  PlacedPupilBounds tilt_bounds_;
  /// Dispersion (see realistic.cpp, "Dispersive lenses"): whether the lens disperses, and an id
  /// that keys each thread's re-indexed copy of the tracer to this camera.
  bool dispersive_ = false;
  /// The glasses' absorption; absorbs_: on and some glass has data.
  optics::LensAbsorption absorption_;
  bool absorbs_ = false;
  /// The internal transmittance at lambda_nm of a path the tracer recorded (1 when !absorbs_).
  double pathTransmittance(const std::vector<Vec3f>& path, bool from_film, double lambda_nm) const {
    return absorbs_ ? absorption_.alongPath(path, from_film, lambda_nm) : 1.0;
  }
  std::uint64_t id_ = 0;
  /// The media's indices (after each surface) every kIndexStep_nm from kIndexFrom_nm, for
  /// re-indexing the tracer by linear interpolation (error < 2e-8, below the float tracer's
  /// rounding; exact evaluation of the formulas costs most of a dispersive camera sample).
  static constexpr double kIndexFrom_nm = kRenderedMin_nm, kIndexTo_nm = kRenderedMax_nm,
                          kIndexStep_nm = 0.25;
  std::vector<double> index_table_;
  /// The float tracer at the wavelength, a per-thread copy re-indexed for it.
  const optics::LensTracer<float>& tracerAt(double lambda_nm) const;
  /// The media's indices before and after each surface at the wavelength (surfaceCount() values
  /// each), from index_table_ (a dispersive lens only).
  void indicesAt(double lambda_nm, double* before, double* after) const;
  /// A dispersive lens's camera ray for a sample whose film ray is f (realistic.cpp).
  std::optional<CameraRay> dispersiveRay(const CameraSample& sample, const FilmRay& f) const;
  /// The camera ray (world space, shutter time from u_time; weight unset) of a ray leaving the
  /// lens at o_lens along d_lens (lens space, mm).
  CameraRay placeRay(const Vec3& o_lens, const Vec3& d_lens, double u_time) const;
  /// The denominator of the weight: z^2, or the centre's sampled area with simple weighting.
  double weightNorm() const;
  /// A surface's axial extent over its clear aperture (lens space z, mm): (min, max).
  static std::pair<double, double> surfaceZRange(const optics::Interface& s);
  /// Lens flare's precomputed data (realistic_flare.cpp); null without flare.
  struct Flare;
  std::shared_ptr<const Flare> flare_;
  void setUpFlare();
  /// With flare: scales the camera ray's weight, per wavelength, by the coatings' transmittance
  /// at every surface the direct path f crosses, at its angles.
  void applyReflectionLosses(const CameraSample& sample, const FilmRay& f, CameraRay& ray) const;
  /// With flare: the coatings' transmittance, per wavelength, of the direct path that enters
  /// the lens along the line (o_lens, d_lens) from the scene (lens space, toward +z); false if
  /// the lens stops it.
  bool reflectionLossesFromScene(const Vec3& o_lens, const Vec3& d_lens,
                                 const std::array<double, kCameraWavelengths>& lambda_nm,
                                 std::array<double, kCameraWavelengths>& t) const;
  /// A ghost path traced from the scene (realistic_flare.cpp): the line (o_lens, d_lens) through
  /// ghost pair k (Flare's order) to the film plane. film_mm: where it lands; front: its first
  /// meeting with the front surface; factor: the aperture shape's transmission times the
  /// coatings' R and T along the path, per wavelength, over the pair's probability.
  struct GhostFromScene {
    Vec2 film_mm;
    Vec3 front;
    double cos_theta = 1;  ///< of the film-side ray to the axis
    std::array<double, kCameraWavelengths> factor{};
  };
  std::optional<GhostFromScene> traceGhostFromScene(
      double u_pair, const Vec3& o_lens, const Vec3& d_lens,
      const std::array<double, kCameraWavelengths>& lambda_nm) const;
  /// With flare, a dispersive lens: the coatings' transmittance at every surface of the direct
  /// path `path` (traced from the film at the hero wavelength lambda_nm, leaving along
  /// out_dir), at that wavelength's indices.
  double heroReflectionLosses(const std::vector<Vec3f>& path, const Vec3f& out_dir,
                              double lambda_nm) const;
  /// Raster position of a film point (lens space, mm): the inverse of filmPoint.
  Vec2 rasterPoint(Vec2 film_mm) const;

  // Importance (realistic_importance.cpp).
  /// Where the line through o_lens with direction d_lens (lens space, mm; toward +z), coming
  /// from the scene, meets the film (tilted or shifted: the placed film; film_mm is then in the
  /// film's frame), traced at lambda_nm (0: the primary wavelength): the film point's raster
  /// position and the importance per unit world area and projected solid angle
  /// at the front element; nullopt if the lens stops it, it misses the film or no camera ray
  /// could have taken that way. With front_hit: also nullopt unless the line enters the lens
  /// there (its first meeting with the front surface).
  struct FilmHit {
    Vec2 raster;
    double importance = 0;
    Vec2 film_mm;
    double cos_theta = 1;  ///< of the film-side ray to the axis
    /// The region generateRay samples for this film point (mm^2) and the ray's geometric
    /// factor there (FilmRay::g_per_mm2: cos^4(theta) / z^2 for an untilted film).
    double area_mm2 = 0, g_per_mm2 = 0;
  };
  /// The importance per unit front area and projected solid angle of a ray that reaches the
  /// film, before the aperture shape and absorption (see the top of realistic_importance.cpp).
  double importanceScale() const;
  /// Whether a raster position lies within the image plus the filter's margin.
  bool onFilm(Vec2 raster) const;
  std::optional<FilmHit> traceToFilm(const Vec3& o_lens, const Vec3& d_lens, double lambda_nm,
                                     const Vec3* front_hit = nullptr,
                                     Vec3* front_out = nullptr) const;
  /// Where sampleWi draws front-surface points for a scene point (lens space): a disc in the
  /// front vertex plane's projection (centre, radius, mm) that holds every point where light
  /// from it enters the lens and reaches the film; radius 0: none does.
  struct FrontDisc {
    Vec2 centre;
    double radius = 0;
  };
  FrontDisc frontDisc(const Vec3& ref_lens) const;
  /// Per field angle theta (parallel light from the scene at azimuth 0): the disc holding the
  /// front points of the rays that reach the film (centre on the x axis; radius < 0: none).
  struct FrontBoundTable {
    double step_rad = 0;
    std::vector<double> centre, radius;
  };
  void buildFrontBounds() const;
  mutable std::unique_ptr<std::once_flag> front_once_ = std::make_unique<std::once_flag>();
  mutable FrontBoundTable front_bounds_;
  /// World <-> lens space (mm).
  // Lens space from world and back at shutter time `time` (a moving camera).
  Vec3 lensFromWorldPoint(const Vec3& p, double time) const;
  Vec3 lensFromWorldVector(const Vec3& v, double time) const;
  Vec3 worldFromLensPoint(const Vec3& p, double time) const;
  Vec3 worldFromLensVector(const Vec3& v, double time) const;
  /// The geometry of a connection from the scene point ref to the front-element point p (normal
  /// n, lens space) drawn uniformly over a disc of disc_area_mm2 in its projection: p_lens, wi,
  /// distance, n_lens and the solid-angle pdf of s; false when degenerate.
  bool connectionGeometry(const Vec3& ref, const Vec3& p, const Vec3& n, double disc_area_mm2,
                          double time, CameraWiSample& s) const;
  /// Camera from world at `time`: camera_from_world_ when the camera does not move, else
  /// `scratch` filled.
  const Transform& cameraFromWorld(double time, Transform& scratch) const;
  Transform camera_from_world_;
  double front_zmin_mm_ = 0, front_zmax_mm_ = 0;  ///< the front surface's axial extent
};

}  // namespace lensim::camera
