// The AGF catalogues of data/glass/agf/, compiled into lensim (glass/agf_data.cpp) so that it
// needs no data files at run time.
#pragma once

#include <span>

namespace lensim::embedded {

struct EmbeddedAgf {
  const char* stem;    ///< the file's stem, the catalogue's name ("schott")
  const char* vendor;  ///< the maker as lensim names it ("Schott")
  const unsigned char* begin;
  const unsigned char* end;  ///< the file's bytes as stored (any encoding parseAgf reads)
};

/// The built-in catalogues in search order: schott, ohara, hoya, cdgm, sumita, hikari (the six
/// makers of the former built-in catalogue, in its order), then the others.
std::span<const EmbeddedAgf> agfFiles();

}  // namespace lensim::embedded
