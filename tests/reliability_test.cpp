// Issue 16: no input can crash, hang or exhaust lensim. Each fault found by fuzzing and fault
// tests is reproduced here by its minimal input in tests/data/reliability/ and must now end in a
// located error (exit 1) or a correct image, quickly and within the memory limit.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli_run.h"
#include "lensim/io/image.h"
#include "lensim/util/file.h"
#include "lensim/util/limits.h"
#include "lensim/util/text.h"

namespace fs = std::filesystem;
using lensim::test::CliResult;

namespace {

const std::string kData = std::string(LENSIM_SOURCE_DIR) + "/tests/data/reliability/";

// Every command runs under `timeout`: a hang fails the test instead of stalling the suite.
CliResult run(const std::string& args) {
  return lensim::test::runLensim("--memory-limit 2G " + args);
}

bool contains(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

// A fresh directory for outputs.
struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() /
           ("lensim-reliability-" + std::to_string(::getpid()) + "-" + std::to_string(counter()++));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string operator/(const std::string& name) const { return (path / name).string(); }
  static int& counter() {
    static int c = 0;
    return c;
  }
  // Leftover temporary files of writeAtomically.
  std::vector<std::string> temporaries() const {
    std::vector<std::string> out;
    for (const auto& e : fs::directory_iterator(path))
      if (contains(e.path().filename().string(), ".tmp-")) out.push_back(e.path().string());
    return out;
  }
};

void expectAllFinite(const std::string& image_path) {
  const lensim::io::Image im = lensim::io::readImage(image_path);
  size_t bad = 0;
  for (float v : im.pixels) bad += !std::isfinite(v);
  EXPECT_EQ(bad, 0u) << image_path;
}

// Expects exit 1 and `file:line:col: error: <message part>` naming the input file.
void expectLocatedError(const CliResult& r, const std::string& file, const std::string& part) {
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(contains(r.out, file + ":")) << r.out;
  EXPECT_TRUE(contains(r.out, "error: ")) << r.out;
  EXPECT_TRUE(contains(r.out, part)) << r.out;
  EXPECT_FALSE(contains(r.out, "Assertion")) << r.out;
}

}  // namespace

// ---- 1: inputs that made Embree abort (ray.valid() assertion, exit 134) ---------------------

TEST(Reliability, NonFiniteNumbersInScenesAreRefusedAtTheirLocation) {
  TempDir dir;
  const struct {
    const char* file;
    const char* where;
    const char* message;
  } cases[] = {
      {"lookat_nan.pbrt", "lookat_nan.pbrt:3:12", "expected a finite number, found nan"},
      {"translate_1e39.pbrt", "translate_1e39.pbrt:3:15", "1e+39 is out of range"},
      {"pointlight_nan.pbrt", "pointlight_nan.pbrt:6:52", "expected a finite number"},
      {"pointlight_inf.pbrt", "pointlight_inf.pbrt:6:52", "found inf"},
      {"distant_from_eq_to.pbrt", "distant_from_eq_to.pbrt:6:1",
       "\"from\" and \"to\" are the same"},
      {"sphere_radius_nan.pbrt", "sphere_radius_nan.pbrt:3:31", "expected a finite number"},
      {"mesh_vertex_inf.pbrt", "mesh_vertex_inf.pbrt:3:48", "found inf"},
      {"arealight_1e300.pbrt", "arealight_1e300.pbrt:6:36", "out of range"},
      {"infinite_1e219.pbrt", "infinite_1e219.pbrt:6:33", "out of range"},
      {"film_iso_nan.pbrt", "film_iso_nan.pbrt:1:72", "expected a finite number"},
      {"film_whitebalance_tiny.pbrt", "film_whitebalance_tiny.pbrt:1:1", "\"whitebalance\""},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.file);
    CliResult r = run("render -q " + kData + c.file + " -o " + (dir / "o.exr"));
    expectLocatedError(r, kData + c.file, c.message);
    EXPECT_TRUE(contains(r.out, c.where)) << r.out;
    EXPECT_FALSE(fs::exists(dir / "o.exr"));
  }
}

TEST(Reliability, RaysEmbreeCannotTraceAreDroppedAndCounted) {
  // Finite but huge eye or light positions make rays Embree refuses: they are dropped, counted,
  // and the image is written with finite pixels.
  TempDir dir;
  for (const char* f : {"eye_huge.pbrt", "eye_huge_ortho.pbrt", "pointlight_huge.pbrt"}) {
    SCOPED_TRACE(f);
    CliResult r = run("render --stats " + kData + f + " -o " + (dir / "o.exr"));
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_TRUE(contains(r.out, "were dropped")) << r.out;
    EXPECT_TRUE(contains(r.out, "invalid rays")) << r.out;
    expectAllFinite(dir / "o.exr");
  }
}

TEST(Reliability, NoPixelIsNaNOrInfinite) {
  // A light near the float limit overflows the film's sums; the pixels stay finite.
  TempDir dir;
  CliResult r = run("render -q " + kData + "infinite_1e38.pbrt -o " + (dir / "o.exr"));
  EXPECT_EQ(r.status, 0) << r.out;
  expectAllFinite(dir / "o.exr");
}

// ---- 2: hangs and runaway memory from small files --------------------------------------------

TEST(Reliability, SizesFromFilesAreCheckedAgainstTheMemoryBudget) {
  const struct {
    const char* args;
    const char* file;
    const char* message;
  } cases[] = {
      {"--memory-limit 512M check", "film_10000.pbrt", "a 10000x10000 film needs about"},
      {"--memory-limit 64M check", "loopsubdiv_level8.pbrt", "loopsubdiv: 8 levels"},
      {"--memory-limit 32M check", "nested_attributes.pbrt", "nested AttributeBegin"},
      {"check", "ply_1e9_faces.pbrt", "claims 1000000000 entries"},
      {"--memory-limit 1G render -q", "tiff_20000.pbrt", "a 20000x20000 image with 3 channels"},
      {"--memory-limit 64M render -q", "brdf_500_wavelengths.pbrt",
       "the BRDF table for 500 wavelengths needs about"},
      {"render -q", "brdf_5000_wavelengths.pbrt", "the count of wavelengths is 5000"},
  };
  TempDir dir;
  for (const auto& c : cases) {
    SCOPED_TRACE(c.file);
    CliResult r =
        lensim::test::runLensim(std::string(c.args) + " " + kData + c.file +
                                (contains(c.args, "render") ? " -o " + (dir / "o.exr") : ""));
    EXPECT_EQ(r.status, 1) << r.out;
    EXPECT_TRUE(contains(r.out, c.message)) << r.out;
    EXPECT_TRUE(contains(r.out, "error: ")) << r.out;
  }
}

TEST(Reliability, OnlyRegularFilesAreRead) {
  TempDir dir;
  ASSERT_EQ(::mkfifo((dir / "fifo").c_str(), 0600), 0);
  fs::create_symlink("loop2", dir / "loop1");
  fs::create_symlink("loop1", dir / "loop2");
  const struct {
    std::string args, message;
  } cases[] = {
      {"lens info " + (dir / "fifo"), "not a regular file"},
      {"check " + (dir / "fifo"), "not a regular file"},
      {"check /dev/zero", "not a regular file"},
      {"lens info /dev/zero", "not a regular file"},
      {"lens info /dev/null", "not a regular file"},
      {"lens info " + dir.path.string(), "it is a directory"},
      {"lens info " + (dir / "loop1"), "Too many levels of symbolic links"},
      {"check " + (dir / "loop1"), "Too many levels of symbolic links"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.args);
    CliResult r = lensim::test::runLensim("--memory-limit 1G " + c.args);
    EXPECT_EQ(r.status, 1) << r.out;
    EXPECT_TRUE(contains(r.out, c.message)) << r.out;
  }
}

TEST(Reliability, ALensWithTooManyRowsIsRefused) {
  TempDir dir;
  {
    std::ofstream out(dir / "rows.dat");
    for (int i = 0; i < 10001; ++i) out << (i % 2 ? "-50" : "50") << " 1 1.5 10\n";
  }
  CliResult r = run("lens info " + (dir / "rows.dat"));
  expectLocatedError(r, dir / "rows.dat", "too many surfaces");
  EXPECT_TRUE(contains(r.out, "rows.dat:10001:1:")) << r.out;
}

// ---- 3: wrong output with exit 0 -------------------------------------------------------------

TEST(Reliability, SampleCountsThatOverflowAreRefused) {
  TempDir dir;
  CliResult r = run("render -q --spp 2147483647 " + kData + "eye_huge.pbrt -o " + (dir / "o.exr"));
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(contains(r.out, "2147483647 samples per pixel: expected 1 to 16777216")) << r.out;
  EXPECT_FALSE(fs::exists(dir / "o.exr"));
  r = run("check " + kData + "pixelsamples_int_max.pbrt");
  expectLocatedError(r, kData + "pixelsamples_int_max.pbrt",
                     "pixelsamples 2147483647 is too large");
  r = run("check " + kData + "stratified_65536.pbrt");
  expectLocatedError(r, kData + "stratified_65536.pbrt", "65536 x 65536 samples per pixel");
}

std::string writeSlowScene(const TempDir& dir, int res, int spp);

TEST(Reliability, AFullDiskIsAnErrorAndLeavesNoFile) {
  // RLIMIT_FSIZE (ulimit -f) makes writes fail like a full disk, without privileges; SIGXFSZ is
  // ignored so that the write fails with EFBIG instead of killing the process.
  TempDir dir;
  const std::string scene = writeSlowScene(dir, 128, 1);  // a 128x128 image: EXR > 4 KB
  for (const char* ext : {"exr", "tif"}) {
    for (const char* limit : {"0", "4"}) {
      SCOPED_TRACE(std::string(ext) + " ulimit -f " + limit);
      const std::string out = dir / (std::string("full.") + ext);
      const std::string cmd = std::string("bash -c \"trap '' XFSZ; ulimit -f ") + limit +
                              "; exec " + LENSIM_BINARY + " render -q " + scene + " -o " + out +
                              "\" 2>&1";
      FILE* p = popen(cmd.c_str(), "r");
      ASSERT_NE(p, nullptr);
      std::string text;
      char buf[512];
      size_t n;
      while ((n = fread(buf, 1, sizeof buf, p)) > 0) text.append(buf, n);
      const int st = pclose(p);
      EXPECT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 1) << text;
      EXPECT_TRUE(contains(text, "error: ")) << text;
      EXPECT_FALSE(fs::exists(out)) << text;
      EXPECT_TRUE(dir.temporaries().empty());
    }
  }
}

// ---- 4: signals and files --------------------------------------------------------------------

// Starts a render in the background, sends `sig` after `delay_s`, returns the exit status.
int renderAndSignal(const std::string& scene, const std::string& out, const char* sig,
                    double delay_s, const std::string& extra = "") {
  const std::string cmd = std::string("bash -c '") + LENSIM_BINARY + " render -q --threads 1 " +
                          extra + " " + scene + " -o " + out + " 2>/dev/null & pid=$!; sleep " +
                          std::to_string(delay_s) + "; kill -" + sig + " $pid; wait $pid; exit $?'";
  const int st = std::system(cmd.c_str());
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

std::string writeSlowScene(const TempDir& dir, int res, int spp) {
  const std::string path = dir / "slow.pbrt";
  std::ofstream f(path);
  f << "Film \"rgb\" \"integer xresolution\" " << res << " \"integer yresolution\" " << res
    << "\nSampler \"independent\" \"integer pixelsamples\" " << spp
    << "\nLookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 45\nWorldBegin\n"
       "LightSource \"point\" \"rgb I\" [10 10 10] \"point3 from\" [0 2 5]\n"
       "Shape \"sphere\" \"float radius\" 1\n";
  return path;
}

TEST(Reliability, SigtermAndSigintStopTheRenderAndWriteTheImage) {
  TempDir dir;
  const std::string scene = writeSlowScene(dir, 64, 1 << 16);
  for (const auto& [sig, status] : {std::pair<const char*, int>{"TERM", 143}, {"INT", 130}}) {
    SCOPED_TRACE(sig);
    const std::string out = dir / (std::string("sig-") + sig + ".exr");
    EXPECT_EQ(renderAndSignal(scene, out, sig, 1.0), status);
    ASSERT_TRUE(fs::exists(out));
    const lensim::io::Image im = lensim::io::readImage(out);
    EXPECT_EQ(im.metadata.count("lensim:partial"), 1u);
    EXPECT_TRUE(dir.temporaries().empty());
  }
}

TEST(Reliability, ASignalAtAnyMomentLeavesThePreviousOrACompleteFile) {
  // A large image takes a while to write; signals at many moments must never leave a temporary
  // file or a truncated image, and the exit status is 0 (done before the signal) or 143.
  TempDir dir;
  const std::string scene = writeSlowScene(dir, 1024, 1);
  const std::string out = dir / "out.exr";
  int statuses[256] = {};
  for (int i = 0; i < 12; ++i) {
    const int st = renderAndSignal(scene, out, "TERM", 0.05 + 0.06 * i);
    ASSERT_TRUE(st == 0 || st == 143) << "status " << st;
    ++statuses[st];
    EXPECT_TRUE(dir.temporaries().empty());
    if (fs::exists(out)) {
      lensim::io::Image im;
      EXPECT_NO_THROW(im = lensim::io::readImage(out));
      EXPECT_EQ(im.width, 1024);
    }
  }
}

TEST(Reliability, WritingThroughASymlinkWritesItsTarget) {
  TempDir dir;
  fs::create_directories(dir.path / "real");
  fs::create_symlink("real/target.exr", dir.path / "link.exr");
  CliResult r = run("render -q " + kData + "eye_huge_ortho.pbrt -o " + (dir / "link.exr"));
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(fs::is_symlink(dir.path / "link.exr"));
  EXPECT_TRUE(fs::is_regular_file(dir.path / "real" / "target.exr"));
  EXPECT_EQ(lensim::resolveWriteTarget(dir / "link.exr"), dir / "real/target.exr");
}

// ---- 5: messages -----------------------------------------------------------------------------

TEST(Reliability, LongTokensAreShortenedAndCheap) {
  TempDir dir;
  {
    std::ofstream f(dir / "token.pbrt");
    f << "WorldBegin\nShape \"sphere\" \"float radius\" \"" << std::string(2000000, 'x') << "\"\n";
    std::ofstream g(dir / "word.pbrt");
    g << std::string(10000000, 'W') << "\n";
  }
  // `timeout 10`: the 10 MB unknown word cost 6 s of edit distance before the fix.
  CliResult r = lensim::test::runLensim("check " + (dir / "token.pbrt"));
  EXPECT_EQ(r.status, 1);
  EXPECT_LT(r.out.size(), 2000u) << r.out.substr(0, 400);
  EXPECT_TRUE(contains(r.out, "bytes)")) << r.out.substr(0, 400);
  const std::string cmd = "timeout 10 " + std::string(LENSIM_BINARY) + " check " +
                          (dir / "word.pbrt") + " > " + (dir / "word.log") + " 2>&1";
  const int st = std::system(cmd.c_str());
  EXPECT_EQ(WEXITSTATUS(st), 1) << "124 means it took more than 10 s";
  EXPECT_LT(fs::file_size(dir / "word.log"), 2000u);
}

TEST(Reliability, UnprintableBytesInMessagesAreEscaped) {
  CliResult r = run("lens info " + kData + "lens_nul_message.dat");
  expectLocatedError(r, kData + "lens_nul_message.dat", "found '4\\x000'");
}

TEST(Reliability, LensNamesWithControlBytesMakeValidSvgAndJson) {
  TempDir dir;
  CliResult r = run("lens draw " + kData + "lens_name_control.dat -o " + (dir / "d.svg"));
  EXPECT_EQ(r.status, 0) << r.out;
  std::ifstream in(dir / "d.svg", std::ios::binary);
  const std::string svg((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (unsigned char c : svg) EXPECT_TRUE(c >= 0x20 || c == '\n' || c == '\t' || c == '\r');
  EXPECT_TRUE(contains(svg, "bad\\x01name")) << svg.substr(0, 2000);
  if (std::system("command -v xmllint > /dev/null 2>&1") == 0) {
    EXPECT_EQ(std::system(("xmllint --noout " + (dir / "d.svg")).c_str()), 0);
  }
  r = run("lens info --json " + kData + "lens_name_control.dat");
  EXPECT_EQ(r.status, 0) << r.out;
}

TEST(Reliability, SceneValueErrorsCarryTheirLocation) {
  const struct {
    const char* file;
    const char* where;
    const char* message;
  } cases[] = {
      {"blackbody_negative.pbrt", ":3:21", "blackbody temperature -5 K is out of range"},
      {"spectrum_decreasing.pbrt", ":3:21", "expected increasing wavelengths"},
      {"encoding_gamma_x.pbrt", ":3:63", "encoding \"gamma x\""},
      {"brdf_1e39.pbrt", "brdf_1e39.brdf:3:13", "the BRDF value of sample 1 is 1e39"},
  };
  TempDir dir;
  for (const auto& c : cases) {
    SCOPED_TRACE(c.file);
    CliResult r = run("render -q " + kData + c.file + " -o " + (dir / "o.exr"));
    EXPECT_EQ(r.status, 1) << r.out;
    EXPECT_TRUE(contains(r.out, c.where)) << r.out;
    EXPECT_TRUE(contains(r.out, c.message)) << r.out;
  }
}

TEST(Reliability, FocusErrorsNameTheLensFile) {
  // A focus distance inside the lens cannot be reached; the error names the lens file.
  CliResult r = run("lens info " + std::string(LENSIM_SOURCE_DIR) +
                    "/lenses/dgauss.50mm.dat --focus-distance 0.001");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_TRUE(contains(r.out, "dgauss.50mm.dat: error: ")) << r.out;
}

// ---- the shared helpers ----------------------------------------------------------------------

TEST(ReliabilityUtil, EscapeTextKeepsValidUtf8AndEscapesTheRest) {
  using lensim::escapeText;
  EXPECT_EQ(escapeText("plain ascii"), "plain ascii");
  EXPECT_EQ(escapeText(std::string("a\0b", 3)), "a\\x00b");
  EXPECT_EQ(escapeText("tab\there\n"), "tab\\there\\n");
  EXPECT_EQ(escapeText("tab\there\n", true), "tab\there\n");
  EXPECT_EQ(escapeText("\x1b[31m"), "\\x1b[31m");
  EXPECT_EQ(escapeText("µm ×"), "µm ×");                     // valid UTF-8 stays
  EXPECT_EQ(escapeText("\xff\xfe"), "\\xff\\xfe");           // invalid bytes
  EXPECT_EQ(escapeText("\xc3"), "\\xc3");                    // truncated sequence
  EXPECT_EQ(escapeText("\xed\xa0\x80"), "\\xed\\xa0\\x80");  // a surrogate
  EXPECT_EQ(escapeText("\x7f"), "\\x7f");
}

TEST(ReliabilityUtil, ShortTokenAndSanitizeMessageCutLongRuns) {
  using lensim::sanitizeMessage;
  using lensim::shortToken;
  EXPECT_EQ(shortToken("short"), "short");
  EXPECT_EQ(shortToken(std::string(100, 'a'), 10), std::string(10, 'a') + "…(+90 bytes)");
  // No UTF-8 sequence is split.
  EXPECT_EQ(shortToken("aaaaaaaaa×b", 10), "aaaaaaaaa…(+3 bytes)");
  const std::string msg = "unknown \"" + std::string(1000000, 'x') + "\" here";
  const std::string s = sanitizeMessage(msg);
  EXPECT_LT(s.size(), 400u);
  EXPECT_TRUE(contains(s, "here"));
  const lensim::Error e(lensim::FileLoc{"f.pbrt", 1, 2}, std::string("bad \0 byte", 10));
  EXPECT_STREQ(e.what(), "f.pbrt:1:2: error: bad \\x00 byte");
}

TEST(ReliabilityUtil, MemorySizesAndCheckedArithmetic) {
  using lensim::parseMemorySize;
  EXPECT_EQ(parseMemorySize("512M"), uint64_t{512} << 20);
  EXPECT_EQ(parseMemorySize("8G"), uint64_t{8} << 30);
  EXPECT_EQ(parseMemorySize("1.5GiB"), uint64_t{3} << 29);
  EXPECT_EQ(parseMemorySize("1000"), 1000u);
  EXPECT_FALSE(parseMemorySize("lots"));
  EXPECT_FALSE(parseMemorySize("-1G"));
  EXPECT_FALSE(parseMemorySize("1Q"));
  EXPECT_FALSE(lensim::checkedMul(uint64_t{1} << 40, uint64_t{1} << 30));
  EXPECT_EQ(lensim::checkedMul(3, 4), 12u);
  EXPECT_FALSE(lensim::checkedAdd(~uint64_t{0}, 1));
  const uint64_t saved = lensim::memoryBudgetBytes();
  lensim::setMemoryBudgetBytes(uint64_t{1} << 20);
  EXPECT_THROW(lensim::checkMemory(2e6, lensim::FileLoc{"x"}, "this"), lensim::Error);
  EXPECT_NO_THROW(lensim::checkMemory(1e5, lensim::FileLoc{"x"}, "this"));
  try {
    lensim::checkMemory(3.0 * (1 << 30), lensim::FileLoc{"x", 3, 4}, "a thing");
  } catch (const lensim::Error& e) {
    EXPECT_STREQ(e.what(),
                 "x:3:4: error: a thing needs about 3.0 GiB, more than the memory limit of 1.0 "
                 "MiB (--memory-limit)");
  }
  lensim::setMemoryBudgetBytes(saved);
  EXPECT_GT(lensim::physicalMemoryBytes(), 0u);
}

TEST(ReliabilityUtil, RequireFiniteAndRange) {
  const lensim::FileLoc loc{"f", 1, 1};
  EXPECT_NO_THROW(lensim::requireFinite(1e38, loc, "x"));
  EXPECT_THROW(lensim::requireFinite(1e39, loc, "x"), lensim::Error);
  EXPECT_THROW(lensim::requireFinite(NAN, loc, "x"), lensim::Error);
  EXPECT_THROW(lensim::requireFinite(-INFINITY, loc, "x"), lensim::Error);
  EXPECT_THROW(lensim::requireInRange(NAN, 0, 1, loc, "x"), lensim::Error);
  EXPECT_NO_THROW(lensim::requireInRange(0.5, 0, 1, loc, "x"));
}

TEST(ReliabilityUtil, ReadRegularFileCapsTheSize) {
  TempDir dir;
  { std::ofstream(dir / "f.txt") << "0123456789"; }
  EXPECT_EQ(lensim::readRegularFile(dir / "f.txt", "test file"), "0123456789");
  EXPECT_THROW(lensim::readRegularFile(dir / "f.txt", "test file", 5), lensim::Error);
  EXPECT_THROW(lensim::readRegularFile(dir / "missing", "test file"), lensim::Error);
  EXPECT_THROW(lensim::readRegularFile("/dev/zero", "test file"), lensim::Error);
}

TEST(ReliabilityUtil, NonFinitePixelsAreReadAsZero) {
  TempDir dir;
  lensim::io::Image im(2, 1, {"R", "G", "B"});
  im.pixels = {NAN, 1, INFINITY, -INFINITY, 0.5f, 2};
  lensim::io::writeImage(dir / "nan.exr", im);
  const lensim::io::Image back = lensim::io::readImage(dir / "nan.exr");
  ASSERT_EQ(back.pixels.size(), 6u);
  EXPECT_EQ(back.pixels, (std::vector<float>{0, 1, 0, 0, 0.5f, 2}));
}

TEST(Reliability, AnExrHeaderCannotClaimMoreThanTheFileHolds) {
  // Found by scripts/fuzz (image): a 347-byte EXR with a string attribute claiming 1.9 GB made
  // OpenEXR allocate that much before reading it.
  try {
    lensim::io::readImage(kData + "exr_huge_attribute.exr");
    FAIL() << "expected an error";
  } catch (const lensim::Error& e) {
    EXPECT_EQ(e.loc().file, kData + "exr_huge_attribute.exr");
    EXPECT_TRUE(contains(e.message(), "attribute \"lensim:camera\" claims 1953391934 bytes"))
        << e.what();
  }
}
