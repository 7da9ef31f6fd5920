// Distributed renders (issue 14): tiles x sample slices x thread counts merge to the single-run
// image bit for bit; merge refuses parts that do not belong together; a render killed with
// SIGKILL at random points and resumed from its checkpoint equals the uninterrupted render; the
// job files of `lensim dispatch` run (their commands in a local shell loop over the indices) and
// the Kubernetes manifest validates against the Kubernetes schema.
#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cli_run.h"
#include "lensim/io/image.h"
#include "lensim/render/parts.h"
#include "lensim/render/renderer.h"
#include "lensim/scene/description.h"
#include "lensim/util/error.h"

namespace fs = std::filesystem;
using namespace lensim;
using render::Part;
using render::PixelBounds;
using render::RenderOptions;

extern char** environ;

namespace {

const std::string kSource = LENSIM_SOURCE_DIR;
const std::string kBinary = LENSIM_BINARY;
const std::string kTiny = kSource + "/tests/data/cluster/tiny.pbrt";

fs::path tempDir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("lensim_cluster_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

/// Runs a shell command line; returns its exit status and output.
test::CliResult sh(const std::string& cmd) {
  test::CliResult r;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

/// A shell word.
std::string q(const fs::path& p) {
  std::string out = "'";
  for (char c : p.string()) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

/// Bit equality of two images' pixels.
bool sameBits(const io::Image& a, const io::Image& b) {
  return a.width == b.width && a.height == b.height && a.channels == b.channels &&
         std::memcmp(a.pixels.data(), b.pixels.data(), a.pixels.size() * sizeof(float)) == 0;
}

/// The R, G, B channels of an image file.
io::Image rgb(const std::string& path) {
  io::Image im = io::readImage(path);
  io::Image out(im.width, im.height, {"R", "G", "B"});
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x)
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = im.at(x, y, *im.channelIndex(out.channels[c]));
  return out;
}

}  // namespace

TEST(TileBounds, PartitionTheBounds) {
  const PixelBounds b{3, 50, 7, 40};
  for (int n = 1; n <= 24; ++n) {
    std::vector<int> hits(size_t(b.area()), 0);
    for (int i = 0; i < n; ++i) {
      const PixelBounds t = render::tileBounds(b, i, n);
      ASSERT_GT(t.area(), 0) << i << "/" << n;
      for (int y = t.y0; y < t.y1; ++y)
        for (int x = t.x0; x < t.x1; ++x) ++hits[size_t(y - b.y0) * b.width() + (x - b.x0)];
    }
    for (int h : hits) ASSERT_EQ(h, 1) << n << " tiles";
  }
  EXPECT_EQ(render::tileGrid({0, 400, 0, 100}, 4), std::make_pair(4, 1));
  EXPECT_EQ(render::tileGrid({0, 100, 0, 100}, 16), std::make_pair(4, 4));
  EXPECT_THROW(render::tileBounds(b, 5, 5), Error);
  EXPECT_THROW(render::tileBounds({0, 4, 0, 4}, 0, 7), Error);  // 7 x 1 in 4 pixels
}

TEST(TileBounds, ParsesTheCommandLine) {
  EXPECT_EQ(render::parseTile("3/16"), std::make_pair(3, 16));
  EXPECT_EQ(render::parseSppRange("16:32"), std::make_pair(16, 32));
  EXPECT_DOUBLE_EQ(render::parseDuration("60s"), 60);
  EXPECT_DOUBLE_EQ(render::parseDuration("500ms"), 0.5);
  EXPECT_DOUBLE_EQ(render::parseDuration("2m"), 120);
  EXPECT_DOUBLE_EQ(render::parseDuration("1.5"), 1.5);
  for (const char* bad : {"16/16", "-1/4", "3", "a/b", "3/0"})
    EXPECT_THROW(render::parseTile(bad), Error) << bad;
  for (const char* bad : {"8:8", "9:8", "8", ":8", "-1:4"})
    EXPECT_THROW(render::parseSppRange(bad), Error) << bad;
  for (const char* bad : {"", "0s", "-1s", "10x", "s"})
    EXPECT_THROW(render::parseDuration(bad), Error) << bad;
}

TEST(FilmSums, OrderIndependentAndExact) {
  // The fixed-point sum of the same values in any order is the same integer; the pixel is
  // sum / weight.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.2, 3.0);
  std::vector<double> v(1000);
  for (double& x : v) x = u(rng);
  render::Int128 a = 0, b = 0;
  for (double x : v) a += render::Film::toFixed(x);
  std::shuffle(v.begin(), v.end(), rng);
  for (double x : v) b += render::Film::toFixed(x);
  EXPECT_TRUE(a == b);
  double exact = 0;
  for (double x : v) exact += x;
  EXPECT_NEAR(double(a) / render::Film::kFixedScale, exact, 1e-9);
  EXPECT_TRUE(render::Film::toFixed(std::nan("")) == 0);
  EXPECT_TRUE(render::Film::toFixed(1e300) == render::Film::toFixed(0x1p52));
}

// Tiles x sample slices x thread counts: the merge of the parts is the single run, bit for bit.
TEST(Merge, TilesTimesSliceTimesThreadsEqualOneRun) {
  const scene::Scene s = scene::loadScene(kTiny);
  RenderOptions base;
  base.keep_sums = true;
  base.threads = 2;
  const render::RenderResult ref = render::render(s, base);
  ASSERT_EQ(ref.stats.spp, 16);
  struct Split {
    int tiles;
    std::vector<std::pair<int, int>> slices;
  };
  const Split splits[] = {
      {1, {{0, 16}}},         {1, {{0, 5}, {5, 16}}},
      {4, {{0, 16}}},         {5, {{0, 1}, {1, 7}, {7, 16}}},
      {6, {{0, 8}, {8, 16}}},
  };
  for (const Split& split : splits)
    for (int threads : {1, 2}) {
      std::vector<Part> parts;
      for (int t = 0; t < split.tiles; ++t)
        for (const auto& range : split.slices) {
          RenderOptions o = base;
          o.threads = threads;
          o.tile = std::make_pair(t, split.tiles);
          o.spp_range = range;
          const render::RenderResult r = render::render(s, o);
          Part p;
          p.path = fmt::format("tile {}/{} spp {}:{}", t, split.tiles, range.first, range.second);
          p.metadata = render::renderIdentity(s, o, render::planRender(s, o), "test");
          p.x_res = s.film.x_resolution, p.y_res = s.film.y_resolution;
          p.bounds = r.bounds;
          p.sums = r.sums;
          parts.push_back(std::move(p));
        }
      const Part merged = render::mergeParts(parts);
      const std::string what = fmt::format("{} tiles x {} slices, {} threads", split.tiles,
                                           split.slices.size(), threads);
      EXPECT_TRUE(merged.bounds == ref.bounds) << what;
      EXPECT_TRUE(merged.sums == ref.sums) << what;
      EXPECT_TRUE(sameBits(render::sumsImage(merged.bounds, merged.sums), ref.image)) << what;
    }
}

// Every sampler gives the same pixels split or whole (each value depends only on the pixel, the
// sample index, the dimension and the seed).
TEST(Merge, EverySamplerSplitsExactly) {
  for (const char* sampler : {"stratified", "independent"}) {
    scene::Scene s = scene::loadScene(kTiny);
    s.sampler.type = sampler;
    RenderOptions base;
    base.keep_sums = true;
    base.threads = 2;
    base.spp = 9;  // stratified: 3 x 3
    const render::RenderResult ref = render::render(s, base);
    std::vector<Part> parts;
    for (int t = 0; t < 2; ++t)
      for (const auto& range : {std::make_pair(0, 4), std::make_pair(4, 9)}) {
        RenderOptions o = base;
        o.tile = std::make_pair(t, 2);
        o.spp_range = range;
        const render::RenderResult r = render::render(s, o);
        Part p;
        p.path = fmt::format("{} tile {} spp {}:{}", sampler, t, range.first, range.second);
        p.metadata = render::renderIdentity(s, o, render::planRender(s, o), "test");
        p.x_res = s.film.x_resolution, p.y_res = s.film.y_resolution;
        p.bounds = r.bounds;
        p.sums = r.sums;
        parts.push_back(std::move(p));
      }
    const Part merged = render::mergeParts(parts);
    EXPECT_TRUE(merged.sums == ref.sums) << sampler;
    EXPECT_TRUE(sameBits(render::sumsImage(merged.bounds, merged.sums), ref.image)) << sampler;
  }
}

// The same through the files and the CLI, and every way merge refuses parts.
TEST(Merge, CliMergesPartsAndRefusesMismatches) {
  const fs::path d = tempDir("merge");
  const std::string L = q(kBinary) + " --quiet render " + q(kTiny) + " --spp 4 ";
  ASSERT_EQ(sh(L + "-o " + q(d / "full.exr")).status, 0);
  for (int t = 0; t < 3; ++t)
    for (const char* r : {"0:1", "1:4"}) {
      const auto res =
          sh(L + fmt::format("--tile {}/3 --spp-range {} --threads {} -o ", t, r, 1 + t % 2) +
             q(d / fmt::format("t{}-{}.exr", t, r[0])));
      ASSERT_EQ(res.status, 0) << res.out;
    }
  auto merge = [&](const std::string& parts) {
    return sh(q(kBinary) + " --quiet merge " + q(d / "m.exr") + " " + parts);
  };
  const std::string all = q(d / "t0-0.exr") + " " + q(d / "t0-1.exr") + " " + q(d / "t1-0.exr") +
                          " " + q(d / "t1-1.exr") + " " + q(d / "t2-0.exr") + " " +
                          q(d / "t2-1.exr");
  auto ok = merge(all);
  ASSERT_EQ(ok.status, 0) << ok.out;
  EXPECT_TRUE(sameBits(rgb((d / "m.exr").string()), rgb((d / "full.exr").string())));
  const io::Image merged = io::readImage((d / "m.exr").string());
  EXPECT_EQ(merged.metadata.at("lensim:spp_total"), "4");
  EXPECT_EQ(merged.metadata.count("lensim:scene_hash"), 1u);
  EXPECT_EQ(merged.metadata.at("lensim:version"), LENSIM_VERSION_FOR_TESTS);
  auto cmp = sh(q(kBinary) + " compare --exact " + q(d / "m.exr") + " " + q(d / "full.exr"));
  EXPECT_EQ(cmp.status, 0) << cmp.out;
  EXPECT_NE(cmp.out.find("identical"), std::string::npos);

  // Mismatches: each refused with exit status 1, a message naming the problem, and no output.
  fs::remove(d / "m.exr");
  ASSERT_EQ(sh(L + "--seed 5 --tile 2/3 --spp-range 1:4 -o " + q(d / "seed.exr")).status, 0);
  ASSERT_EQ(sh(L + "--tile 2/3 --spp-range 0:3 -o " + q(d / "overlap.exr")).status, 0);
  ASSERT_EQ(sh(q(kBinary) + " --quiet render " + q(kTiny) +
               " --spp 8 --tile 2/3 --spp-range 1:4 -o " + q(d / "spp.exr"))
                .status,
            0);
  {
    std::ifstream in(kTiny);
    std::stringstream text;
    text << in.rdbuf();
    std::string scene = text.str();
    scene.replace(scene.find("maxdepth\" 5"), 11, "maxdepth\" 4");
    // Same directory so the relative paths resolve.
    const fs::path other = fs::path(kTiny).parent_path() / fmt::format(".other-{}.pbrt", getpid());
    std::ofstream(other) << scene;
    const auto r = sh(q(kBinary) + " --quiet render " + q(other) +
                      " --spp 4 --tile 2/3 --spp-range 1:4 -o " + q(d / "scene.exr"));
    fs::remove(other);
    ASSERT_EQ(r.status, 0) << r.out;
  }
  const std::string five = q(d / "t0-0.exr") + " " + q(d / "t0-1.exr") + " " + q(d / "t1-0.exr") +
                           " " + q(d / "t1-1.exr") + " " + q(d / "t2-0.exr");
  struct Case {
    std::string parts, message;
  };
  const Case cases[] = {
      {five + " " + q(d / "seed.exr"), "different seeds"},
      {five + " " + q(d / "scene.exr"), "different scenes"},
      {five + " " + q(d / "spp.exr"), "different samples per pixel"},
      {all + " " + q(d / "overlap.exr"), "overlapping parts"},
      {q(d / "t0-0.exr") + " " + q(d / "t0-1.exr") + " " + q(d / "t1-0.exr") + " " +
           q(d / "t1-1.exr"),
       "missing tile"},
      {five, "missing samples 1:4"},
      {all + " " + q(d / "full.exr"), "not a lensim part"},
      {all + " " + q(d / "nothere.exr"), "no such file"},
  };
  for (const Case& c : cases) {
    const auto r = merge(c.parts);
    EXPECT_EQ(r.status, 1) << c.message << "\n" << r.out;
    EXPECT_NE(r.out.find(c.message), std::string::npos) << c.message << "\n" << r.out;
    EXPECT_EQ(r.out.find("Assertion"), std::string::npos);
    EXPECT_FALSE(fs::exists(d / "m.exr")) << c.message;
  }
  // Parts must be EXR.
  const auto png = sh(L + "--tile 0/3 -o " + q(d / "p.png"));
  EXPECT_EQ(png.status, 1);
  EXPECT_NE(png.out.find("use an .exr output"), std::string::npos) << png.out;
  const auto bad = sh(L + "--tile 3/3 -o " + q(d / "p.exr"));
  EXPECT_EQ(bad.status, 1);
  EXPECT_NE(bad.out.find("expected I/N with 0 <= I < N"), std::string::npos) << bad.out;
  const auto range = sh(L + "--spp-range 2:9 -o " + q(d / "p.exr"));
  EXPECT_EQ(range.status, 1);
  EXPECT_NE(range.out.find("not a non-empty range of the 4 samples"), std::string::npos)
      << range.out;
  fs::remove_all(d);
}

// Tiles of a crop window, and merges of merges (`merge --part`): still the single run.
TEST(Merge, CropWindowsAndMergesOfMerges) {
  const fs::path d = tempDir("crop");
  const std::string L =
      q(kBinary) + " --quiet render " + q(kTiny) + " --spp 4 --cropwindow 0.1 0.85 0.2 0.9 ";
  ASSERT_EQ(sh(L + "-o " + q(d / "full.exr")).status, 0);
  std::string slice0, slice1;
  for (int t = 0; t < 3; ++t) {
    const fs::path a = d / fmt::format("a{}.exr", t), b = d / fmt::format("b{}.exr", t);
    ASSERT_EQ(sh(L + fmt::format("--tile {}/3 --spp-range 0:1 -o ", t) + q(a)).status, 0);
    ASSERT_EQ(sh(L + fmt::format("--tile {}/3 --spp-range 1:4 -o ", t) + q(b)).status, 0);
    slice0 += " " + q(a), slice1 += " " + q(b);
  }
  // The first slice of every tile merged into one part, then merged with the rest.
  auto r = sh(q(kBinary) + " --quiet merge --part " + q(d / "s0.exr") + slice0);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("missing samples 1:4"), std::string::npos) << r.out;
  r = sh(q(kBinary) + " --quiet merge --part --partial-samples " + q(d / "s0.exr") + slice0);
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_EQ(io::readImage((d / "s0.exr").string()).metadata.at("lensim:spp_range"), "0:1");
  // Partial samples must still be the same in every pixel.
  r = sh(q(kBinary) + " --quiet merge --partial-samples " + q(d / "x.exr") + " " + q(d / "a0.exr") +
         " " + q(d / "a1.exr") + " " + q(d / "b2.exr"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("every pixel needs the same samples"), std::string::npos) << r.out;
  r = sh(q(kBinary) + " --quiet merge " + q(d / "m.exr") + " " + q(d / "s0.exr") + slice1);
  ASSERT_EQ(r.status, 0) << r.out;
  const io::Image m = rgb((d / "m.exr").string());
  EXPECT_EQ(m.width, 36);  // ceil(48 * 0.85) - ceil(48 * 0.1)
  EXPECT_TRUE(sameBits(m, rgb((d / "full.exr").string())));
  // A part of the whole image does not fit a cropped render.
  ASSERT_EQ(
      sh(q(kBinary) + " --quiet render " + q(kTiny) + " --spp 4 --part -o " + q(d / "whole.exr"))
          .status,
      0);
  r = sh(q(kBinary) + " --quiet merge " + q(d / "x.exr") + " " + q(d / "whole.exr") + slice0 +
         slice1);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("different pixel bounds"), std::string::npos) << r.out;
  fs::remove_all(d);
}

namespace {

pid_t spawn(const std::vector<std::string>& args) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = -1;
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  if (posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&fa);
  return pid;
}

int waitFor(pid_t pid) {
  int st = 0;
  waitpid(pid, &st, 0);
  return st;
}

}  // namespace

// Killed with SIGKILL at random points (during a checkpoint write too) and resumed: the image is
// the uninterrupted render's, bit for bit. 20 times.
TEST(Checkpoint, ResumeAfterSigkillEqualsUninterruptedRender) {
  using Clock = std::chrono::steady_clock;
  auto seconds = [](Clock::time_point a) {
    return std::chrono::duration<double>(Clock::now() - a).count();
  };
  const fs::path d = tempDir("resume");
  const std::string ref = (d / "ref.exr").string(), ck = (d / "ck.exr").string(),
                    out = (d / "out.exr").string();
  const std::vector<std::string> common = {kBinary, "--quiet", "render", kTiny, "--spp", "32"};
  auto args = [&](std::vector<std::string> extra) {
    std::vector<std::string> a = common;
    a.insert(a.end(), extra.begin(), extra.end());
    return a;
  };
  // 1 thread so that the 6 tiles finish one after another; a checkpoint every 10 ms.
  const std::vector<std::string> killed =
      args({"--threads", "1", "-o", out, "--checkpoint", ck, "--checkpoint-every", "10ms"});
  ASSERT_EQ(waitFor(spawn(args({"--threads", "2", "-o", ref}))), 0);
  const io::Image want = rgb(ref);
  // Calibration: when the first checkpoint appears (set-up done) and when the render ends, so
  // that the kills land while it renders.
  const auto t0 = Clock::now();
  const pid_t cal = spawn(killed);
  double t_first = -1;
  while (waitpid(cal, nullptr, WNOHANG) == 0) {
    if (t_first < 0 && fs::exists(ck)) t_first = seconds(t0);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  const double t_end = seconds(t0);
  if (t_first < 0) t_first = 0.5 * t_end;
  ASSERT_TRUE(render::readPart(ck).metadata.count("lensim:partial") == 0);
  fs::copy_file(ck, d / "complete.exr");
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> when(t_first, std::max(t_first, 0.95 * t_end) + 1e-3);
  int in_progress = 0, fresh = 0, finished = 0;
  for (int run = 0; run < 20; ++run) {
    fs::remove(ck), fs::remove(out);
    const pid_t pid = spawn(killed);
    ASSERT_GT(pid, 0);
    bool reaped = false;
    if (run % 2 == 0) {
      // At a random moment (during a checkpoint write too).
      std::this_thread::sleep_for(std::chrono::duration<double>(when(rng)));
    } else {
      // Once the checkpoint shows 1..5 of the 6 tiles done, so that half of the kills surely
      // land while tiles are rendering, however loaded the machine is (timed kills alone may all
      // land before the first or after the last tile there).
      const int target = 1 + (run / 2) % 5;
      while (!reaped) {
        if (waitpid(pid, nullptr, WNOHANG) != 0) {
          reaped = true;
          break;
        }
        try {
          if (fs::exists(ck)) {
            const Part p = render::readPart(ck);
            if (std::count(p.tile_done.begin(), p.tile_done.end(), 1) >= target) break;
          }
        } catch (const std::exception&) {
          // replaced between the check and the read: look again
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
    }
    if (!reaped) {
      kill(pid, SIGKILL);
      waitFor(pid);
    }
    int st;
    if (fs::exists(ck)) {
      const Part p = render::readPart(ck);  // never half-written
      const int done = int(std::count(p.tile_done.begin(), p.tile_done.end(), 1));
      in_progress += done > 0 && done < int(p.tile_done.size());
      finished += done == int(p.tile_done.size());
      st = waitFor(spawn(args({"--threads", "2", "-o", out, "--resume", ck})));
    } else {
      ++fresh;  // killed before the first checkpoint: start again, as the job scripts do
      st = waitFor(spawn(args({"--threads", "2", "-o", out})));
    }
    ASSERT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 0) << "run " << run;
    ASSERT_TRUE(sameBits(rgb(out), want)) << "run " << run;
  }
  std::printf(
      "20 kills (render %.3f..%.3f s): %d resumed with some tiles done, %d with none or "
      "before the first checkpoint, %d after all tiles were done\n",
      t_first, t_end, in_progress, 20 - in_progress - finished, finished);
  // The kills must have hit renders in progress, not only unstarted or finished ones.
  EXPECT_GE(in_progress, 5);
  // A checkpoint of another render is refused.
  const auto other = sh(q(kBinary) + " --quiet render " + q(kTiny) + " --spp 32 --seed 9 -o " +
                        q(d / "x.exr") + " --resume " + q(d / "complete.exr"));
  EXPECT_EQ(other.status, 1);
  EXPECT_NE(other.out.find("cannot resume: the checkpoint is of another render (lensim:seed"),
            std::string::npos)
      << other.out;
  fs::remove_all(d);
}

namespace {

/// The `command:` arrays of a generated manifest, in order (JSON flow sequences).
std::vector<std::vector<std::string>> manifestCommands(const fs::path& yaml) {
  std::ifstream in(yaml);
  std::vector<std::vector<std::string>> cmds;
  std::string line;
  while (std::getline(in, line)) {
    const size_t at = line.find("command: ");
    if (at != std::string::npos)
      cmds.push_back(nlohmann::json::parse(line.substr(at + 9)).get<std::vector<std::string>>());
  }
  return cmds;
}

}  // namespace

// The Kubernetes Indexed Job's commands, run in a local shell loop over the completion indices
// (the volume is a local directory), then the merge Job's: the single-run image, bit for bit.
TEST(Dispatch, KubernetesCommandsRunLocallyAndMergeExactly) {
  for (const char* split : {"tiles", "samples"}) {
    const fs::path d = tempDir(std::string("k8s_") + split);
    const auto gen = sh("cd " + q(d) + " && " + q(kBinary) + " dispatch " + q(kTiny) +
                        " --engine kubernetes --jobs 4 --split " + split + " --lensim " +
                        q(kBinary) + " --workdir " + q(d) + " --threads 1 --spp 8 --image " +
                        "lensim:test --output merged.exr");
    ASSERT_EQ(gen.status, 0) << gen.out;
    const fs::path yaml = d / "lensim-jobs" / "job.yaml";
    ASSERT_TRUE(fs::exists(yaml));
    std::ifstream in(yaml);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("completionMode: Indexed"), std::string::npos);
    EXPECT_NE(text.find("completions: 4"), std::string::npos);
    EXPECT_NE(text.find("JOB_COMPLETION_INDEX"), std::string::npos);
    const auto cmds = manifestCommands(yaml);
    ASSERT_EQ(cmds.size(), 2u);
    ASSERT_EQ(cmds[0].size(), 3u);
    for (int i = 0; i < 4; ++i) {
      const auto r =
          sh("JOB_COMPLETION_INDEX=" + std::to_string(i) + " /bin/sh -c " + q(cmds[0][2]));
      ASSERT_EQ(r.status, 0) << split << " index " << i << ": " << r.out;
    }
    const auto m = sh("/bin/sh -c " + q(cmds[1][2]));
    ASSERT_EQ(m.status, 0) << m.out;
    ASSERT_EQ(
        sh(q(kBinary) + " --quiet render " + q(kTiny) + " --spp 8 -o " + q(d / "ref.exr")).status,
        0);
    EXPECT_TRUE(sameBits(rgb((d / "merged.exr").string()), rgb((d / "ref.exr").string()))) << split;
    // The checkpoints are removed once a part is done.
    EXPECT_FALSE(fs::exists(d / "lensim-jobs" / "parts" / "part-0.ckpt.exr"));
    fs::remove_all(d);
  }
}

// The Slurm array job script and merge script, run by bash over the array indices as Slurm
// would (scripts/test-slurm runs them under real slurmctld/slurmd).
TEST(Dispatch, SlurmScriptsRunLocallyAndMergeExactly) {
  const fs::path d = tempDir("slurm");
  const auto gen = sh("cd " + q(d) + " && " + q(kBinary) + " dispatch " + q(kTiny) +
                      " --engine slurm --jobs 3 --lensim " + q(kBinary) +
                      " --spp 8 --cpus-per-task 1 --output merged.exr");
  ASSERT_EQ(gen.status, 0) << gen.out;
  const fs::path jobs = d / "lensim-jobs";
  std::ifstream in(jobs / "render.sbatch");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("#SBATCH --array=0-2"), std::string::npos) << text;
  EXPECT_NE(text.find("#SBATCH --cpus-per-task=1"), std::string::npos);
  EXPECT_TRUE(fs::exists(jobs / "submit.sh"));
  for (int i = 0; i < 3; ++i) {
    const auto r =
        sh("SLURM_ARRAY_TASK_ID=" + std::to_string(i) + " bash " + q(jobs / "render.sbatch"));
    ASSERT_EQ(r.status, 0) << r.out;
  }
  const auto m = sh("bash " + q(jobs / "merge.sbatch"));
  ASSERT_EQ(m.status, 0) << m.out;
  ASSERT_EQ(
      sh(q(kBinary) + " --quiet render " + q(kTiny) + " --spp 8 -o " + q(d / "ref.exr")).status, 0);
  EXPECT_TRUE(sameBits(rgb((d / "merged.exr").string()), rgb((d / "ref.exr").string())));
  // Errors before anything is written.
  const auto bad = sh("cd " + q(d) + " && " + q(kBinary) + " dispatch " + q(kTiny) +
                      " --engine slurm --jobs 97 --outdir x");
  EXPECT_EQ(bad.status, 1);
  EXPECT_NE(bad.out.find("do not fit"), std::string::npos) << bad.out;
  fs::remove_all(d);
}

// The manifest against the Kubernetes API schema, offline (kubernetes-models from npm, installed
// by scripts/install-deps into tests/k8s); a broken manifest must fail the same check.
TEST(Dispatch, KubernetesManifestValidatesAgainstTheSchema) {
  const fs::path tool = fs::path(kSource) / "tests" / "k8s";
  if (!fs::exists(tool / "node_modules" / "kubernetes-models") || sh("command -v node").status != 0)
    GTEST_SKIP() << "kubernetes-models is not installed in tests/k8s (scripts/install-deps "
                    "installs it with npm)";
  const fs::path d = tempDir("schema");
  const auto gen = sh("cd " + q(d) + " && " + q(kBinary) + " dispatch " + q(kTiny) +
                      " --engine kubernetes --jobs 16 --cpu 4 --parallelism 8");
  ASSERT_EQ(gen.status, 0) << gen.out;
  const fs::path yaml = d / "lensim-jobs" / "job.yaml";
  const auto good = sh("node " + q(tool / "validate.mjs") + " " + q(yaml));
  EXPECT_EQ(good.status, 0) << good.out;
  EXPECT_NE(good.out.find("2 objects valid"), std::string::npos) << good.out;
  std::ifstream in(yaml);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // Broken manifests fail: a count that is not an integer, a completion mode Kubernetes lacks.
  for (const auto& [from, to] :
       {std::pair<std::string, std::string>{"completions: 16", "completions: many"},
        {"completionMode: Indexed", "completionMode: Indexes"}}) {
    std::string broken = text;
    broken.replace(broken.find(from), from.size(), to);
    std::ofstream(d / "bad.yaml") << broken;
    const auto bad = sh("node " + q(tool / "validate.mjs") + " " + q(d / "bad.yaml"));
    EXPECT_EQ(bad.status, 1) << to << ": " << bad.out;
  }
  fs::remove_all(d);
}
