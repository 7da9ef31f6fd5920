// Lens cross-section diagrams with exactly traced rays, drawn as SVG.
//
// The diagram is built in lens space (millimetres, meridional x-z plane) by the exact tracer
// itself, then drawn to scale; the drawing code only maps coordinates.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "lensim/optics/focus.h"
#include "lensim/optics/tilt_shift.h"
#include "lensim/util/svg.h"

namespace lensim::optics {

/// Where the ray bundles start.
enum class DiagramSource {
  Film,   ///< bundles from film points at fractions of the film half-diagonal
  Scene,  ///< parallel bundles from the scene at fractions of the half field of view
};

struct DiagramOptions {
  std::vector<double> fields{0.0, 0.7, 1.0};  ///< fractions (film height or field angle)
  int rays = 11;                              ///< rays per bundle, across the pupil
  double film_diagonal_mm = 35.0;
  DiagramSource source = DiagramSource::Film;
  /// The lens tilted and shifted against the film (optics/tilt_shift.h): the diagram is then the
  /// section through the lens axis that holds the film's normal (or, shifted only, the film's
  /// centre), drawn with the lens axis horizontal; the film is drawn where it crosses that
  /// section, and film bundles start on it at `fields` fractions of its half-length there, about
  /// the point nearest the film's centre (fields {-1, 0, 1} show both ends).
  TiltShift tilt_shift;
};

/// One traced ray of a bundle, in lens space (z, x; y = 0).
struct DiagramRay {
  int field = 0;             ///< index into the bundle fields
  Ray start;                 ///< the ray as handed to the tracer
  std::vector<Vec3> points;  ///< the tracer's path, then a short extension (if it got through)
  TraceResult result;        ///< the tracer's result
  std::string color;         ///< SVG colour; empty: the field's palette colour
  std::string ghost;         ///< "I,J" for a ray of a ghost path (setGhostBundle); else empty
};

/// A glass element: the closed outline of its cross-section, (z, x) points in mm.
struct DiagramElement {
  int front_surface = 0;      ///< the element lies between this surface and the next
  std::vector<Vec2> outline;  ///< x = z (mm), y = height (mm)
};

/// Everything a lens diagram shows, in lens space.
struct LensDiagram {
  std::string title;
  std::vector<std::string> annotations;
  std::vector<DiagramElement> elements;
  std::vector<std::vector<Vec2>>
      bare_surfaces;  ///< refracting surfaces not part of a glass element
  /// Mirror profiles (split at a central hole), drawn as thick reflecting curves.
  std::vector<std::vector<Vec2>> mirrors;
  /// Central obscurations of refracting or plane surfaces (a secondary mirror's shadow).
  std::vector<std::vector<Vec2>> obscurations;
  std::optional<double> stop_z_mm, stop_opening_mm, stop_outer_mm;  ///< semi heights
  double film_z_mm = 0, film_half_height_mm = 0, rear_vertex_z_mm = 0;
  /// A tilted or shifted film: its ends in the section, (z, x) in mm; unset: the film is the
  /// segment x = +-film_half_height_mm at film_z_mm.
  std::optional<std::array<Vec2, 2>> film_segment;
  std::vector<double> field_values;  ///< film heights (mm) or field angles (deg) of the bundles
  DiagramSource source = DiagramSource::Film;
  std::vector<DiagramRay> rays;
  double z_min = 0, z_max = 0, x_max = 0;  ///< extent of the drawing (mm)
};

/// Traces the bundles and outlines the elements of a focused lens.
LensDiagram buildLensDiagram(const FocusedLens& lens, const DiagramOptions& opts);

/// Replaces the diagram's bundles by the rays of the two-reflection ghost that reflects first at
/// surface `first` and then at `second` (as `lens ghosts` numbers them): `rays` rays of an axial
/// bundle from infinity, spread across the part of the entrance beam that gets through the
/// ghost path, traced exactly (ghostTracer) to the film. Throws lensim::Error for a pair
/// ghostPathInterfaces refuses.
void setGhostBundle(LensDiagram& d, const FocusedLens& lens, int first, int second, int rays);

/// Pixels per millimetre that fit the diagram into a w x h cell.
double fitScale(const LensDiagram& d, double w, double h);

/// Draws the diagram into the cell (x, y, w, h) at `px_per_mm`.
void drawLensDiagram(svg::Document& doc, const LensDiagram& d, double x, double y, double w,
                     double h, double px_per_mm);

/// A sheet of diagrams in a grid (`columns`; 0: two columns when there are several), each
/// fitted to its cell or all at the scale of the largest (`same_scale`).
std::string lensDiagramSheet(const std::vector<LensDiagram>& diagrams, bool same_scale,
                             int columns = 0);

}  // namespace lensim::optics
