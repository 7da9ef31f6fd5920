// The glass library: where lens files' glass names are looked up, and the process-wide choices
// about glasses found nowhere or used outside their formula's range.
//
// Search order for a glass name (docs/glass.md):
//   1. catalogues the user added, in the order added: `--glass-catalog FILE` options (in command
//      line order), then the scene's realistic camera "string glasscatalog" (in scene order);
//   2. the catalogues named by the LENSIM_GLASS_PATH environment variable (colon-separated files,
//      or folders whose *.agf files are taken in name order);
//   3. the built-in catalogues (GlassCatalog::builtin()).
// A Zemax file's GCAT line moves the catalogues it names (by name, any of the above) to the front,
// in its order, for that file's GLAS lines.
#pragma once

#include <string>
#include <vector>

#include "lensim/optics/glass.h"
#include "lensim/util/error.h"

namespace lensim::optics {

/// Adds a catalogue file (.agf or .csv) to the user's catalogues; a file already added is not
/// added twice. Throws lensim::Error: at `named_at` when the file does not exist, at the file's
/// own line:col when it does not parse.
void addGlassCatalogFile(const std::string& path, const FileLoc& named_at = {});

/// The glass library now: the user's catalogues, LENSIM_GLASS_PATH's, the built-in ones. The
/// reference stays valid for the life of the process (a later addGlassCatalogFile makes a new
/// library; the old stays).
const GlassCatalog& glassLibrary();

/// `--model-glass`: a glass name found in no catalogue is replaced by the model glass made from
/// the n_d and V_d its lens file gives (reported as such). Off: such a name is an error.
void setModelGlassAllowed(bool allowed);
bool modelGlassAllowed();

/// `--glass-extrapolate`: a wavelength outside a glass formula's valid range (its catalogue's
/// LD) is used with a warning. Off: it is an error.
void setGlassExtrapolationAllowed(bool allowed);
bool glassExtrapolationAllowed();

/// Throws lensim::Error at `loc` (a warning instead when extrapolation is allowed, appended to
/// `diagnostics`) if `lambda_nm` is outside the glass's valid range; `what` names the wavelength.
void checkGlassRange(const Glass& glass, double lambda_nm, const FileLoc& loc,
                     const std::string& what, std::vector<Diagnostic>* diagnostics = nullptr);

/// The least a glass's valid range must span for renders: 405-700 nm, the narrowest span the
/// makers' catalogues give their current glasses (Ohara's high-index glasses from the h line,
/// 404.66 nm; Nikon's and Hikari's to 700 nm). Outside it lie 0.28 %, 0.05 % and 0.69 % of the
/// weight of the CIE 1931 observer's x-bar, y-bar and z-bar over 360-830 nm.
inline constexpr double kRenderGlassFrom_nm = 405, kRenderGlassTo_nm = 700;

/// The renderer's check of a lens's media, traced at `from_nm`-`to_nm`: a dispersive glass whose
/// valid range misses part of kRenderGlassFrom_nm-kRenderGlassTo_nm is an error without a
/// location (the camera reports it at its Camera line), a warning in `diagnostics` when
/// extrapolation is allowed; the glasses valid over that span but not over all of from-to are
/// used at its ends, stated in one note. `lens` names the lens file.
void checkRenderGlassRanges(const std::vector<Glass>& glasses, double from_nm, double to_nm,
                            const std::string& lens, std::vector<Diagnostic>* diagnostics);

}  // namespace lensim::optics
