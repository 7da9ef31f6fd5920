// Lens file formats besides pbrt's `.dat` tables: Zemax `.zmx` (sequential), lentil's JSON
// database, ISET3d's JSON lens files and lensim's own JSON lens format; writers for `.dat`,
// lensim JSON and `.zmx`; and the catalogue of named lenses shipped in `lenses/`.
//
// Every reader fills one LensPrescription (prescription.h) with `file:line` on every surface and
// throws lensim::Error (`file:line:col: error: ...`) for what it cannot model.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "lensim/optics/prescription.h"

namespace lensim::optics {

/// Decodes a text file's bytes to UTF-8: UTF-16 LE/BE with a byte-order mark, UTF-8 (with or
/// without a BOM) or ASCII, and anything else read as Latin-1 (ISO 8859-1, as older Zemax files
/// and vendors' glass catalogues are). Throws a located error for malformed UTF-16.
std::string decodeTextFile(std::string_view bytes, const std::string& path);

/// A whitespace-separated field of a line of a text lens file or glass catalogue, with its
/// 1-based column (for `file:line:col` errors).
struct LineField {
  std::string_view text;
  int col;
};

/// The fields of `line` separated by runs of the characters in `separators`.
std::vector<LineField> splitFields(std::string_view line, std::string_view separators = " \t");

/// Parses a Zemax `.zmx` file (sequential mode). Surfaces: STANDARD, EVENASPH, ODDASPH, TOROIDAL
/// (with CONI, PARM); UNIT MM/CM/IN/M; GLAS (catalogue name with the file's n_d/V_d, ___BLANK model
/// glass); DIAM (semi-diameter; without it, or 0, computed from real rays as OpticStudio does:
/// auto_semi_diameter.h), STOP, DISZ (INFINITY for the object); WAVM/WAVL + PWAV;
/// ENPD / FNUM / OBNA / FLOA set the stop's size. Anything else that changes the optics (coordinate
/// breaks, other surface types, mirrors, tilts, non-sequential mode) is refused at its line.
LensPrescription parseZmx(std::string_view bytes, const std::string& path);

/// Parses a JSON lens file: lensim's own format (docs/lens-format.md, docs/lens.schema.json),
/// ISET3d's (`surfaces` with `radius`, `thickness`, `ior`/`n`, `semi_aperture`) or one design of
/// lentil's database (`lentil_key` selects it; empty: the file must hold a single design).
LensPrescription parseLensJson(std::string_view text, const std::string& path,
                               const std::string& lentil_key = "");

/// Writes a prescription as lensim JSON (always possible).
std::string writeLensJson(const LensPrescription& p);
/// Writes a prescription as a Zemax `.zmx` file (sequential, millimetres, FLOA: the stop's
/// semi-diameter is its DIAM). A lens with tilted or decentred surfaces gets a coordinate break
/// (order 0) before each surface whose frame is not the previous one's moved along its axis.
/// Throws lensim::Error naming what cannot be written (non-rotational surfaces, odd aspheric
/// terms, a medium with an index but no dispersion, folds, configurations).
std::string writeLensZmx(const LensPrescription& p);
/// Writes a prescription as a pbrt `.dat` table. Throws lensim::Error naming the surface and
/// what cannot be written (aspheres, cylinders, a stop with curvature...).
std::string writeLensDat(const LensPrescription& p);

/// Resolves a lens name: `lentil:KEY` (lentil's database, e.g. lentil:0003), `lenses:NAME`
/// (a file in lensim's lenses/ catalogue, any format), else a path. Returns the file path and
/// the lentil key ("" for none).
struct LensRef {
  std::string path;
  std::string lentil_key;
};
LensRef resolveLensName(const std::string& name);

/// nlohmann::json keeps no positions, so the line of every element of an array of objects is
/// found by a small scan of the text: the offsets of the '{' that open the elements of the array
/// that is the value of `key` (at any depth; the n-th such array is chosen by `occurrence`).
std::vector<size_t> arrayElementOffsets(std::string_view text, std::string_view key,
                                        int occurrence = 0);
/// The line and column of a byte offset of a text.
FileLoc locAt(std::string_view text, size_t offset, const std::string& path);

/// Where the `lenses/` catalogue is (LENSIM_LENSES_DIR, else the source tree's lenses/).
std::string lensCatalogueDir();

}  // namespace lensim::optics
