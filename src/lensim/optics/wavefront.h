// The complex pupil function of one field and its Fourier optics: the point spread function
// (FFT of the pupil) and the optical transfer function (FFT of the PSF), in the Debye
// approximation on the film plane.
//
// The pupil's edge is the forward beam's: the boundary of the entrance-pupil region whose rays
// from the object point get through (bisected along 256 azimuths), traced forward to its
// image-space direction cosines, a polygon. Rays traced back from P' see a wider cone where
// spherical aberration is large (the forward marginal ray misses P'), so they only give W.
// The pupil is sampled on a regular grid of image-space direction cosines (times the image-side
// index n') inside that edge: rays are traced backward from the image point P' on the film, one per
// grid cell, and the optical path from P' to the object-side reference (a sphere about the object
// point, or a plane normal to the chief ray for an object at infinity) gives the wave aberration W
// relative to the chief ray: the reference sphere about P' is exact by construction, and on a
// direction-cosine grid the film-plane field is the plain 2-D Fourier transform
//   U(dx) = sum A exp(i 2 pi (W + n' alpha . dx) / lambda),
// so the PSF pitch is lambda / (M step) for an M-point transform and the OTF at grid shift k is at
// spatial frequency k step / lambda. The amplitude is uniform over the passing cone (no
// apodization: the small change of the irradiance across the pupil, a few percent at f/2, is
// left out, as in the usual FFT MTF), and W is taken to first order in the aberration (the
// optical path along each traced ray to the reference, Hopkins' definition). Cells on the
// pupil's edge are supersampled (4x4) into a fractional amplitude. The grid is refined (64 to
// 512 cells across) until W changes by less than half a wave (a quarter for PSF images) between
// neighbouring cells, so that the phase is not aliased.
//
// The FFTs use FFTW3 (Debian's libfftw3-dev): a well-kept, fast library for arbitrary sizes;
// the transforms here are 128^2 to 1024^2 complex points.
#pragma once

#include <complex>
#include <optional>
#include <vector>

#include "lensim/optics/field_rays.h"

namespace lensim::optics {

/// Pupil samples on an n x n grid of n' direction cosines (row-major, x fastest).
struct PupilFunction {
  int n = 0;
  double step = 0;                ///< n' direction-cosine spacing between samples
  Vec2 centre;                    ///< n' (alpha, beta) at the grid centre
  std::vector<double> amplitude;  ///< 0 (blocked) to 1, fractional on the edge
  std::vector<double> opd_waves;  ///< W / lambda where the amplitude is > 0, else 0
  double wavelength_nm = kDLineNm;
  Vec2 image_point_mm;  ///< P' on the film
  long rays_traced = 0;
  double rms_opd_waves = 0;   ///< RMS of W over the pupil, piston removed (amplitude weighted)
  double max_step_waves = 0;  ///< largest change of W between neighbouring passing cells
  std::vector<Vec2> edge;     ///< the forward beam's edge, n' direction cosines at P'

  /// n' sin u of the forward beam's half-width about the grid centre: the largest distance of
  /// its edge from the centre (on axis, the image-space numerical aperture of the real
  /// marginal ray).
  double halfWidth() const;
};

/// The pupil function of the bundle at the wavelength, seen from image point P' on the plane
/// z = film_z. `cells`: samples across; 0 picks `min_cells` and doubles it (up to `max_cells`)
/// until W changes by less than `max_step_waves` between neighbouring cells. The PSF's field of
/// view is lambda / step, and a wave slope of s waves per cell moves a ray s of that field from P':
/// the OTF at the grid's frequencies needs s < 1/2; a PSF image without wrapped energy, and the
/// MTF summed between those frequencies (mtf.h), s < 1/4. nullopt when no ray of the bundle
/// gets through.
std::optional<PupilFunction> computePupilFunction(const LensSystem& lens, const FieldBundle& b,
                                                  double film_z_mm, Vec2 image_point_mm,
                                                  double wavelength_nm, int cells = 0,
                                                  double max_step_waves = 0.5, int max_cells = 512,
                                                  int min_cells = 64);

/// PSF and OTF of a pupil function, on an M x M grid with M = 2 n (no wrap-around in the OTF).
struct FourierOptics {
  int m = 0;
  double psf_pitch_mm = 0;                ///< lambda / (M step)
  double frequency_step = 0;              ///< cycles/mm per OTF sample: step / lambda
  std::vector<double> psf;                ///< M x M, centred: P' at (M/2, M/2); sums to 1
  std::vector<std::complex<double>> otf;  ///< M x M, zero frequency at (0, 0), wrapped; 1 there
  double strehl = 0;  ///< PSF peak on the grid over that of the same pupil without aberration

  /// OTF at (nu_x, nu_y) cycles/mm by bilinear interpolation (0 beyond the grid's reach).
  std::complex<double> otfAt(double nu_x, double nu_y) const;
  /// OTF along x (tangential, nu_y = 0) or y (sagittal, nu_x = 0) at any frequency: the
  /// Fourier sum of the PSF's line spread function at exactly that frequency, not an
  /// interpolation between the grid's frequencies (cutoff / n apart, too coarse where an
  /// aberrated lens's MTF falls steeply at low frequencies).
  std::complex<double> otfAlongAxis(double nu, bool along_y) const;
  std::vector<double> lsf_x, lsf_y;  ///< PSF summed over y / over x, index m/2 at P'
  /// PSF at a film offset from P' (mm) by bilinear interpolation (0 outside the grid).
  double psfAt(double dx, double dy) const;
};

FourierOptics fourierOptics(const PupilFunction& pupil);

/// The MTF of an aberration-free circular pupil at nu / cutoff in [0, 1]:
/// (2/pi)(arccos v - v sqrt(1 - v^2)); 0 beyond.
double perfectMtf(double v);

}  // namespace lensim::optics
