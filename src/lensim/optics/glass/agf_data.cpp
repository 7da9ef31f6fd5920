// The built-in AGF catalogues, embedded byte for byte with the assembler's .incbin (the files
// are several megabytes, one of them UTF-16: a string literal would not do).
// LENSIM_GLASS_AGF_DIR is data/glass/agf/ (src/lensim/optics/CMakeLists.txt).
#include "lensim/optics/glass/embedded.h"

#define LENSIM_AGF(stem)                                                                    \
  asm(".pushsection .rodata\n.balign 16\n.hidden lensim_agf_" #stem "_begin\n.globl lensim_agf_" #stem \
      "_begin\nlensim_agf_" #stem "_begin:\n.incbin \"" LENSIM_GLASS_AGF_DIR "/" #stem           \
      ".agf\"\n.hidden lensim_agf_" #stem "_end\n.globl lensim_agf_" #stem "_end\nlensim_agf_" #stem \
      "_end:\n.popsection\n");                                                              \
  extern "C" const unsigned char lensim_agf_##stem##_begin[];                              \
  extern "C" const unsigned char lensim_agf_##stem##_end[];

LENSIM_AGF(schott)
LENSIM_AGF(ohara)
LENSIM_AGF(hoya)
LENSIM_AGF(cdgm)
LENSIM_AGF(sumita)
LENSIM_AGF(hikari)
LENSIM_AGF(nikon)
LENSIM_AGF(lightpath)
LENSIM_AGF(rpo)
LENSIM_AGF(corning)
LENSIM_AGF(heraeus)
LENSIM_AGF(lzos)
LENSIM_AGF(isuzu)
LENSIM_AGF(zeon)
LENSIM_AGF(topas)
LENSIM_AGF(arton)
LENSIM_AGF(infrared)
LENSIM_AGF(umicore)
LENSIM_AGF(birefringent)
LENSIM_AGF(misc)
LENSIM_AGF(archer)
LENSIM_AGF(liebetraut)
LENSIM_AGF(rad_hard)

namespace lensim::embedded {

#define LENSIM_AGF_ENTRY(stem, vendor) {#stem, vendor, lensim_agf_##stem##_begin, lensim_agf_##stem##_end}

std::span<const EmbeddedAgf> agfFiles() {
  static const EmbeddedAgf files[] = {
      LENSIM_AGF_ENTRY(schott, "Schott"),        LENSIM_AGF_ENTRY(ohara, "Ohara"),
      LENSIM_AGF_ENTRY(hoya, "Hoya"),            LENSIM_AGF_ENTRY(cdgm, "CDGM"),
      LENSIM_AGF_ENTRY(sumita, "Sumita"),        LENSIM_AGF_ENTRY(hikari, "Hikari"),
      LENSIM_AGF_ENTRY(nikon, "Nikon"),          LENSIM_AGF_ENTRY(lightpath, "LightPath"),
      LENSIM_AGF_ENTRY(rpo, "RPO"),              LENSIM_AGF_ENTRY(corning, "Corning"),
      LENSIM_AGF_ENTRY(heraeus, "Heraeus"),      LENSIM_AGF_ENTRY(lzos, "LZOS"),
      LENSIM_AGF_ENTRY(isuzu, "Isuzu"),          LENSIM_AGF_ENTRY(zeon, "Zeon"),
      LENSIM_AGF_ENTRY(topas, "Topas"),          LENSIM_AGF_ENTRY(arton, "Arton"),
      LENSIM_AGF_ENTRY(infrared, "Infrared"),    LENSIM_AGF_ENTRY(umicore, "Umicore"),
      LENSIM_AGF_ENTRY(birefringent, "Birefringent"), LENSIM_AGF_ENTRY(misc, "Misc"),
      LENSIM_AGF_ENTRY(archer, "Archer"),        LENSIM_AGF_ENTRY(liebetraut, "Liebetraut"),
      LENSIM_AGF_ENTRY(rad_hard, "RadHard"),
  };
  return files;
}

}  // namespace lensim::embedded
