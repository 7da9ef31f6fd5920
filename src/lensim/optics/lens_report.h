// The lens-info JSON: the keys `lensim lens info --json` and the explorer's /api/lens share,
// built in one place so the two cannot drift apart. Lengths in mm along the axis (z from the
// front vertex), focus distances in m (docs/conventions.md).
#pragma once

#include <nlohmann/json.hpp>

#include "lensim/optics/focus.h"
#include "lensim/optics/lens_system.h"
#include "lensim/optics/tilt_shift.h"

namespace lensim::optics {

/// Front to rear vertex; for a folded (mirror) lens, the axial extent of its surfaces.
double lensLength(const LensSystem& lens);
/// Front vertex to film; for a folded (mirror) lens, the axial extent of its surfaces and film.
double totalTrack(const LensSystem& lens);

/// One object per surface: index, file line, radius, thickness (the last one: to the film),
/// index after, clear aperture, z, stop flag; mirror, obscuration and the non-spherical shape
/// (conic, aspheric terms by power, x radius, radius of rotation) where present.
nlohmann::json surfacesJson(const LensSystem& lens);

/// One object per glass element (each medium other than air): its surfaces, file line, glass,
/// kind, n_d, V_d (null where undefined) and the index at the analysis wavelength.
nlohmann::json elementsJson(const LensSystem& lens);

/// The warnings and notes of the file, the lens and its focusing, as text lines.
nlohmann::json diagnosticsJson(const FocusedLens& fl);

/// The first-order data of a focused lens both reports show: "lens" (name, layout, surface
/// count, stated focal length), focal lengths, stop, pupils, f-numbers, lengths, focus, field of
/// view for a film of this diagonal, and "diagnostics". Callers add their own keys.
nlohmann::json firstOrderJson(const FocusedLens& fl, double film_diagonal_mm);

/// A lens tilted and shifted against the film (tilt_shift.h): the shift and how far from the
/// axis a film of this diagonal reaches; for a tilt also the hinge line, the Scheimpflug point
/// and the plane of focus (first-order). Both `lens info --tilt --shift --json` and the
/// explorer's "tilt_shift" block.
nlohmann::json tiltShiftJson(const FocusedLens& fl, const TiltShift& ts, double film_diagonal_mm);

}  // namespace lensim::optics
