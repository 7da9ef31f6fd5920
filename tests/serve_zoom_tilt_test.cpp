// The explorer's zoom and tilt/shift parameters (issue 30): /api/lens with config, focal, tiltx,
// tilty, shiftx, shifty reports what `lensim lens info --config / --focal-length / --tilt /
// --shift --json` prints, the hinge distance J = f / sin(tilt) (closed form, Merklinger), and
// refuses bad values with a message.
#include <gtest/gtest.h>
#include <httplib.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <thread>

#include "cli_run.h"
#include "lensim/camera/camera.h"
#include "lensim/camera/realistic.h"
#include "lensim/scene/description.h"
#include "lensim/serve/preview.h"
#include "lensim/serve/server.h"

using nlohmann::json;

namespace {

const std::string kSource = LENSIM_SOURCE_DIR;
const std::string kZoom = kSource + "/tests/data/lenses/nikon_zoom_80_200.zmx";
const std::string kDgauss = kSource + "/lenses/dgauss.50mm.dat";

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

class ServeZoomTilt : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    lensim::serve::ServerConfig c;
    c.port = 0;
    // The second folder's ids are prefixed "1:".
    c.lens_folders = {kSource + "/lenses", kSource + "/tests/data/lenses"};
    c.scene = kSource + "/scenes/demo/demo.pbrt";
    server = new lensim::serve::Server(c);
    thread = new std::thread([] { server->run(); });
    for (int i = 0; i < 200; ++i) {
      httplib::Client cli("127.0.0.1", server->port());
      if (cli.Get("/api/info")) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  static void TearDownTestSuite() {
    server->stop();
    thread->join();
    delete thread;
    delete server;
  }
  static json get(const std::string& path, int status = 200) {
    httplib::Client c("127.0.0.1", server->port());
    c.set_read_timeout(60, 0);
    auto r = c.Get(path.c_str());
    EXPECT_TRUE(r) << path;
    if (!r) return {};
    EXPECT_EQ(r->status, status) << path << ": " << r->body;
    return json::parse(r->body);
  }
  static json lensInfo(const std::string& args) {
    auto r = lensim::test::runLensim("lens info " + args + " --film-diagonal 43.3 --json");
    EXPECT_EQ(r.status, 0) << r.out;
    // Log lines (the zoom setting) go to stderr, merged here: the JSON is the last object.
    const size_t at = r.out.find("{\n");
    return at == std::string::npos ? json{} : json::parse(r.out.substr(at));
  }
  static inline lensim::serve::Server* server = nullptr;
  static inline std::thread* thread = nullptr;
};

TEST_F(ServeZoomTilt, ZoomRangeIsReportedOnlyForLensesWithConfigurations) {
  json z = get("/api/lens?lens=1:nikon_zoom_80_200.zmx&focus=inf&diagonal=43.3");
  ASSERT_TRUE(z.contains("zoom")) << z.dump();
  // The range spans the configurations' EFLs, as `lens info --configs` lists them.
  auto r = lensim::test::runLensim("lens info --configs " + kZoom + " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  json configs = json::parse(r.out.substr(r.out.find('{')))["configurations"];
  double lo = 1e300, hi = -1e300;
  for (const json& c : configs) {
    lo = std::min(lo, c["effective_focal_length_mm"].get<double>());
    hi = std::max(hi, c["effective_focal_length_mm"].get<double>());
  }
  EXPECT_EQ(z["zoom"]["configurations"].get<int>(), int(configs.size()));
  EXPECT_NEAR(z["zoom"]["min_effective_focal_length_mm"].get<double>(), lo, 1e-9 * hi);
  EXPECT_NEAR(z["zoom"]["max_effective_focal_length_mm"].get<double>(), hi, 1e-9 * hi);
  EXPECT_GT(lo, 70);  // an 80-200 mm zoom
  EXPECT_LT(hi, 220);
  EXPECT_FALSE(get("/api/lens?lens=dgauss.50mm.dat&focus=inf").contains("zoom"));
}

TEST_F(ServeZoomTilt, FocalLengthAndConfigurationGiveTheNumbersOfLensInfo) {
  const double want = 135;
  json j =
      get("/api/lens?lens=1:nikon_zoom_80_200.zmx&focus=inf&diagonal=43.3&aperture=1000&focal=" +
          num(want));
  EXPECT_NEAR(j["zoom"]["requested_focal_length_mm"].get<double>(), want, 1e-12);
  EXPECT_NEAR(j["zoom"]["achieved_effective_focal_length_mm"].get<double>(), want, 1e-7 * want);
  EXPECT_NEAR(j["effective_focal_length_mm"].get<double>(), want, 1e-7 * want);
  json info = lensInfo(kZoom + " --focal-length " + num(want) + " --focus-distance inf");
  for (const char* key : {"effective_focal_length_mm", "back_focal_length_mm", "f_number",
                          "total_track_mm", "film_distance_mm"})
    EXPECT_NEAR(j[key].get<double>(), info[key].get<double>(), 1e-9) << key;
  json c2 = get("/api/lens?lens=1:nikon_zoom_80_200.zmx&focus=inf&diagonal=43.3&config=2");
  EXPECT_EQ(c2["zoom"]["configuration"].get<int>(), 2);
  json info2 = lensInfo(kZoom + " --config 2 --focus-distance inf");
  EXPECT_NEAR(c2["effective_focal_length_mm"].get<double>(),
              info2["effective_focal_length_mm"].get<double>(), 1e-9);
  // The diagram follows the zoom.
  httplib::Client c("127.0.0.1", server->port());
  auto d1 = c.Get("/api/diagram?lens=1:nikon_zoom_80_200.zmx&focal=90");
  auto d2 = c.Get("/api/diagram?lens=1:nikon_zoom_80_200.zmx&focal=180");
  ASSERT_TRUE(d1 && d2);
  EXPECT_EQ(d1->status, 200);
  EXPECT_NE(d1->body, d2->body);
}

TEST_F(ServeZoomTilt, TiltReportsTheHingeAndPlaneOfFocusOfLensInfo) {
  json j = get("/api/lens?lens=dgauss.50mm.dat&focus=3&diagonal=43.3&tiltx=-5&shifty=3");
  ASSERT_TRUE(j.contains("tilt_shift")) << j.dump();
  const json& ts = j["tilt_shift"];
  // Closed form: J = f / sin(tilt) (a tilt about one axis: the tilt angle is that angle).
  const double f = j["effective_focal_length_mm"].get<double>();
  EXPECT_NEAR(ts["tilt_angle_deg"].get<double>(), 5, 1e-9);
  EXPECT_NEAR(ts["hinge_distance_mm"].get<double>(), f / std::sin(5 * std::numbers::pi / 180),
              1e-6 * f);
  EXPECT_NEAR(ts["film_reach_from_axis_mm"].get<double>(), 43.3 / 2 + 3, 1e-12);
  json info = lensInfo(kDgauss + " --focus-distance 3 --tilt=-5,0 --shift=0,3");
  const json& it = info["tilt_shift"];
  for (const char* key : {"hinge_distance_mm", "tilt_angle_deg", "focus_plane_to_film_deg",
                          "focus_plane_to_lens_plane_deg", "focus_plane_object_distance_mm"})
    EXPECT_NEAR(ts[key].get<double>(), it[key].get<double>(), 1e-9) << key;
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(ts["hinge_point_mm"][k].get<double>(), it["hinge_point_mm"][k].get<double>(), 1e-9);
  // Shift alone: no hinge.
  json s = get("/api/lens?lens=dgauss.50mm.dat&focus=3&shiftx=2");
  EXPECT_FALSE(s["tilt_shift"].contains("hinge_distance_mm"));
  EXPECT_FALSE(get("/api/lens?lens=dgauss.50mm.dat&focus=3").contains("tilt_shift"));
}

TEST_F(ServeZoomTilt, BadZoomAndTiltValuesAreRefusedWithAMessage) {
  auto error = [](const std::string& path, int status, const std::string& words) {
    json e = get(path, status);
    EXPECT_NE(e.value("error", "").find(words), std::string::npos) << path << ": " << e.dump();
  };
  const std::string zoom = "/api/lens?lens=1:nikon_zoom_80_200.zmx";
  error(zoom + "&focal=500", 422, "outside the zoom range");
  error(zoom + "&config=2&focal=100", 400, "not both");
  error(zoom + "&config=99", 422, "99");
  error(zoom + "&config=1.5", 400, "whole number");
  error("/api/lens?lens=dgauss.50mm.dat&focal=50", 422, "single configuration");
  error("/api/lens?lens=dgauss.50mm.dat&tiltx=50", 400, "tiltx");
  error("/api/lens?lens=dgauss.50mm.dat&shifty=nan", 400, "shifty");
  error("/api/preview?view=z&lens=dgauss.50mm.dat&focal=50", 422, "single configuration");
  error("/api/preview?view=z&lens=1:nikon_zoom_80_200.zmx&focal=500", 422, "zoom range");
}

// The preview renders through the tilted and shifted lens: the same camera a scene with
// "lenstilt" and "lensshift" gets (PreviewRenderer::previewScene puts them on it), frames
// streamed to the end, a different picture from the untilted lens's.
TEST_F(ServeZoomTilt, PreviewRendersTiltAndShift) {
  lensim::serve::PreviewRenderer previews;
  lensim::serve::PreviewRequest pr;
  pr.scene_path = kSource + "/scenes/demo/demo.pbrt";
  pr.lens_path = kDgauss;
  pr.aperture_diameter_mm = 10;
  pr.focus_distance_m = 3;
  pr.width = 48;
  pr.tilt_shift.tilt_deg = {3, 0};
  pr.tilt_shift.shift_mm = {0, 2};
  const lensim::scene::Scene prepared = previews.previewScene(pr);
  ASSERT_TRUE(prepared.camera.realistic);
  EXPECT_EQ(prepared.camera.realistic->tilt_shift.tilt_deg.x, 3);
  EXPECT_EQ(prepared.camera.realistic->tilt_shift.shift_mm.y, 2);
  const std::string described = lensim::camera::makeCamera(prepared)->describe();
  EXPECT_NE(described.find("lens shift (0, 2) mm, tilt (3, 0) deg"), std::string::npos)
      << described;
  auto stream = [](const std::string& extra) {
    httplib::Client c("127.0.0.1", server->port());
    c.set_read_timeout(60, 0);
    auto r =
        c.Get(("/api/preview?lens=dgauss.50mm.dat&fnumber=5&focus=3&width=48&spp=2&view=tz" + extra)
                  .c_str());
    EXPECT_TRUE(r);
    if (!r) return std::string();
    EXPECT_EQ(r->status, 200) << r->body.substr(0, 300);
    EXPECT_NE(r->body.find("event: done"), std::string::npos) << r->body.substr(0, 300);
    // The last frame's PNG.
    const size_t at = r->body.rfind("\"png\":\"");
    EXPECT_NE(at, std::string::npos);
    return at == std::string::npos ? std::string()
                                   : r->body.substr(at, r->body.find('"', at + 7) - at);
  };
  const std::string level = stream(""), tilted = stream("&tiltx=3&shifty=2");
  EXPECT_GT(tilted.size(), 100u);
  EXPECT_NE(level, tilted);
}

// The preview renders the zoom position the optics show: the camera gets "focallength" (or
// "configuration") and its lens has the EFL lens info gives for it; two focal lengths render
// different pictures.
TEST_F(ServeZoomTilt, PreviewRendersTheZoomPosition) {
  lensim::serve::PreviewRenderer previews;
  lensim::serve::PreviewRequest pr;
  pr.scene_path = kSource + "/scenes/demo/demo.pbrt";
  pr.lens_path = kZoom;
  pr.aperture_diameter_mm = 10;
  pr.focus_distance_m = 5;
  pr.width = 48;
  pr.zoom_focal_length_mm = 100;
  const lensim::scene::Scene prepared = previews.previewScene(pr);
  ASSERT_TRUE(prepared.camera.realistic);
  EXPECT_EQ(prepared.camera.realistic->zoom_focal_length_mm, 100);
  const json info = lensInfo(kZoom + " --focal-length 100 --focus-distance 5");
  auto cam = lensim::camera::makeCamera(prepared);
  auto* realistic = dynamic_cast<const lensim::camera::RealisticCamera*>(cam.get());
  ASSERT_NE(realistic, nullptr);
  EXPECT_NEAR(realistic->lens().paraxial.effective_focal_length_mm,
              info["effective_focal_length_mm"].get<double>(), 1e-9);
  pr.zoom_focal_length_mm.reset();
  pr.configuration = 3;
  auto tele = lensim::camera::makeCamera(previews.previewScene(pr));
  auto* r3 = dynamic_cast<const lensim::camera::RealisticCamera*>(tele.get());
  ASSERT_NE(r3, nullptr);
  EXPECT_NEAR(
      r3->lens().paraxial.effective_focal_length_mm,
      lensInfo(kZoom + " --config 3 --focus-distance 5")["effective_focal_length_mm"].get<double>(),
      1e-9);
  auto stream = [](const std::string& extra) {
    httplib::Client c("127.0.0.1", server->port());
    c.set_read_timeout(60, 0);
    auto r = c.Get(("/api/preview?lens=1:nikon_zoom_80_200.zmx&fnumber=4&focus=5&width=48&spp=2"
                    "&view=zz" +
                    extra)
                       .c_str());
    EXPECT_TRUE(r);
    if (!r) return std::string();
    EXPECT_EQ(r->status, 200) << r->body.substr(0, 300);
    EXPECT_NE(r->body.find("event: done"), std::string::npos) << r->body.substr(0, 300);
    const size_t at = r->body.rfind("\"png\":\"");
    EXPECT_NE(at, std::string::npos);
    return at == std::string::npos ? std::string()
                                   : r->body.substr(at, r->body.find('"', at + 7) - at);
  };
  const std::string wide = stream("&focal=90"), tele_png = stream("&focal=180");
  EXPECT_GT(wide.size(), 100u);
  EXPECT_NE(wide, tele_png);
}

// The diagram shows the tilted and shifted lens: the film drawn across the section, bundles at
// both ends and the middle; untilted, the film is the usual upright segment.
TEST_F(ServeZoomTilt, DiagramDrawsTheTiltedAndShiftedFilm) {
  httplib::Client c("127.0.0.1", server->port());
  c.set_read_timeout(60, 0);
  auto level = c.Get("/api/diagram?lens=dgauss.50mm.dat&focus=2");
  auto tilted = c.Get("/api/diagram?lens=dgauss.50mm.dat&focus=2&tiltx=-8&shifty=4");
  auto zoomed = c.Get("/api/diagram?lens=1:nikon_zoom_80_200.zmx&focal=120&tilty=3");
  ASSERT_TRUE(level && tilted && zoomed);
  ASSERT_EQ(tilted->status, 200) << tilted->body;
  ASSERT_EQ(zoomed->status, 200) << zoomed->body;
  EXPECT_EQ(level->body.find("film (tilted/shifted)"), std::string::npos);
  EXPECT_NE(tilted->body.find("film (tilted/shifted)"), std::string::npos);
  EXPECT_NE(tilted->body.find("tilt (-8, 0)°, shift (0, 4) mm"), std::string::npos);
  EXPECT_NE(tilted->body.find("film -"), std::string::npos);  // the bundle at the far end
  EXPECT_NE(zoomed->body.find("tilt (0, 3)°"), std::string::npos);
  // The zoomed lens's focal length in the diagram's caption.
  const json info = lensInfo(kZoom + " --focal-length 120 --focus-distance inf");
  char caption[64];
  std::snprintf(caption, sizeof caption, "f = %.2f mm",
                info["effective_focal_length_mm"].get<double>());
  EXPECT_NE(zoomed->body.find(caption), std::string::npos) << caption;
  // An anamorphic lens tilted about x cannot be drawn in its x-z section: drawn untilted, saying
  // so, and the view's numbers still come.
  auto ana = c.Get("/api/diagram?lens=toroidal-anamorphic.50mm.zmx&tiltx=4");
  ASSERT_TRUE(ana);
  EXPECT_EQ(ana->status, 200) << ana->body.substr(0, 300);
  EXPECT_NE(ana->body.find("drawn untilted and unshifted"), std::string::npos);
  EXPECT_EQ(ana->body.find("film (tilted/shifted)"), std::string::npos);
  EXPECT_TRUE(get("/api/view?lens=toroidal-anamorphic.50mm.zmx&tiltx=4").contains("lens"));
}

}  // namespace
