// The web server on its own (no daemon, no browser; light enough for the sanitizer build):
// routing, the web.* configuration, malformed and unknown requests, the camera view drawn
// where the detections are, the stream's content, its bounded per-client queues and abrupt
// disconnects.
#include <atomic>
#include <cctype>
#include <cmath>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/aruco.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "http_client.h"
#include "ips/config/config.h"
#include "ips/core/clock.h"
#include "ips/core/error.h"
#include "ips/web/web.h"

namespace ips {
namespace {

using test::free_tcp_port;
using test::http_get;
using test::raw_request;

TEST(WebRoute, RoutesKnownPathsAndRefusesTheRest) {
  using K = Route::Kind;
  EXPECT_EQ(route_request("GET", "/").kind, K::kPage);
  EXPECT_EQ(route_request("GET", "/status.json").kind, K::kStatus);
  EXPECT_EQ(route_request("GET", "/layout.json").kind, K::kLayout);
  EXPECT_EQ(route_request("GET", "/events").kind, K::kEvents);
  const Route a = route_request("GET", "/assets/app.js");
  EXPECT_EQ(a.kind, K::kAsset);
  EXPECT_EQ(a.name, "app.js");
  const Route j = route_request("GET", "/camera/red.jpg");
  EXPECT_EQ(j.kind, K::kCameraJpeg);
  EXPECT_EQ(j.name, "red");
  EXPECT_EQ(route_request("GET", "/camera/cam-2.json").kind, K::kCameraJson);
  EXPECT_EQ(route_request("GET", "/camera/red.png").kind, K::kNotFound);
  EXPECT_EQ(route_request("GET", "/camera/.jpg").kind, K::kNotFound);
  EXPECT_EQ(route_request("GET", "/camera/../etc/passwd.jpg").kind, K::kNotFound);
  EXPECT_EQ(route_request("GET", "/assets/../../x").kind, K::kNotFound);
  EXPECT_EQ(route_request("GET", "/nope").kind, K::kNotFound);
  EXPECT_EQ(route_request("POST", "/status.json").kind, K::kBadMethod);
  EXPECT_EQ(route_request("GET", "status.json").kind, K::kBadRequest);
  EXPECT_EQ(route_request("GET", std::string("/a\x01", 3)).kind, K::kBadRequest);
  EXPECT_EQ(route_request("GET", "/" + std::string(300, 'a')).kind, K::kBadRequest);
  ASSERT_NE(find_asset("index.html"), nullptr);
  EXPECT_NE(std::string(reinterpret_cast<const char*>(find_asset("index.html")->data), find_asset("index.html")->size)
                .find("/assets/app.js"),
            std::string::npos);
  EXPECT_EQ(find_asset("nothing.js"), nullptr);
}

std::string config_with(const std::string& web) {
  return "cameras:\n  - {name: a, source: file, path: /tmp, intrinsics: " + std::string(IPS_TEST_DATA_DIR) +
         "/ou2023/intrinsics_red.yaml}\nmodel_file: " + std::string(IPS_TEST_DATA_DIR) +
         "/ou2023/intrinsics_red.yaml\n" + web;
}

TEST(WebConfig, ListenIsCheckedAndNamedInErrors) {
  const DaemonConfig off = parse_config(config_with(""), "t.yaml");
  EXPECT_TRUE(off.web.listen.empty());
  const DaemonConfig on =
      parse_config(config_with("web: {listen: \"localhost:8081\", floor: [0, 0, 4.88, 4.88]}\n"), "t.yaml");
  EXPECT_EQ(on.web.host, "127.0.0.1");
  EXPECT_EQ(on.web.port, 8081);
  EXPECT_EQ(on.web.floor.size(), 4u);
  for (const std::string bad :
       {"web: {listen: 8080}\n", "web: {listen: \"127.0.0.1:99999\"}\n", "web: {listen: \"nohost:80\"}\n",
        "web: {listen: \"1.2.3:80\"}\n", "web: {listen: \"127.0.0.1:\"}\n", "web: {}\n"}) {
    try {
      parse_config(config_with(bad), "t.yaml");
      ADD_FAILURE() << "accepted: " << bad;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("web.listen"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("t.yaml:"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(parse_config(config_with("web: {listen: \"127.0.0.1:80\", floor: [1, 2, 0, 3]}\n"), "t.yaml"),
               InputError);
  EXPECT_THROW(parse_config(config_with("web: {listen: \"127.0.0.1:80\", colour: red}\n"), "t.yaml"), InputError);
}

// A frame with two markers drawn by OpenCV at known places: the detections a camera thread
// would hand over (the exact corners the drawing used).
FrameSnapshot synthetic_frame(std::uint64_t sequence) {
  FrameSnapshot s;
  s.sequence = sequence;
  s.gray = cv::Mat(1080, 1920, CV_8UC1, cv::Scalar(200));
  const auto dict = cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_100);
  const std::vector<std::pair<int, cv::Point>> markers = {{3, {400, 300}}, {17, {1300, 700}}};
  for (const auto& [id, at] : markers) {
    cv::Mat m;
    cv::aruco::drawMarker(dict, id, 120, m, 1);
    cv::rectangle(s.gray, cv::Rect(at.x - 30, at.y - 30, 180, 180), cv::Scalar(255), cv::FILLED);
    m.copyTo(s.gray(cv::Rect(at, cv::Size(120, 120))));
    MarkerDetection d;
    d.id = id;
    d.corners_px = {{{double(at.x), double(at.y)},
                     {at.x + 120.0, double(at.y)},
                     {at.x + 120.0, at.y + 120.0},
                     {double(at.x), at.y + 120.0}}};
    s.detections.push_back(d);
  }
  return s;
}

class WebServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    WebConfig c;
    c.host = "127.0.0.1";
    c.port = free_tcp_port();
    c.listen = "127.0.0.1:" + std::to_string(c.port);
    c.update_rate_hz = 50;
    c.max_clients = 4;
    server_ = std::make_unique<WebServer>(c, "DICT_4X4_100");
    port_ = server_->port();
    taps_ = server_->set_cameras({"red", "white"});
    server_->set_layout(R"({"cameras": []})");
    server_->set_status(R"({"type": "ipsd.status", "cameras": []})");
    // The "camera thread" of red: hands over a frame whenever one is wanted.
    camera_ = std::thread([this] {
      std::uint64_t seq = 0;
      while (!stop_) {
        ++seq;
        if (taps_[0]->wanted()) {
          const FrameSnapshot s = synthetic_frame(seq);
          taps_[0]->offer(s.gray, s.detections, s.sequence, monotonic_ns());
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    });
  }
  void TearDown() override {
    stop_ = true;
    camera_.join();
    server_.reset();
  }
  std::unique_ptr<WebServer> server_;
  std::vector<std::shared_ptr<FrameTap>> taps_;
  std::thread camera_;
  std::atomic<bool> stop_{false};
  int port_ = 0;
};

TEST_F(WebServerTest, ServesThePageAndJsonAndRefusesMalformedRequests) {
  auto page = http_get(port_, "/");
  EXPECT_EQ(page.status, 200);
  EXPECT_NE(page.headers.find("text/html"), std::string::npos);
  EXPECT_NE(page.body.find("<svg id=\"map\""), std::string::npos);
  EXPECT_EQ(http_get(port_, "/assets/app.js").status, 200);
  const auto bodies_js = http_get(port_, "/assets/bodies.js");
  EXPECT_EQ(bodies_js.status, 200);
  EXPECT_NE(bodies_js.headers.find("text/javascript"), std::string::npos);
  EXPECT_NE(page.body.find("/assets/bodies.js"), std::string::npos);
  EXPECT_EQ(nlohmann::json::parse(http_get(port_, "/status.json").body)["type"], "ipsd.status");
  EXPECT_EQ(http_get(port_, "/layout.json").status, 200);

  EXPECT_EQ(http_get(port_, "/nope").status, 404);
  EXPECT_EQ(http_get(port_, "/assets/nothing.js").status, 404);
  EXPECT_EQ(http_get(port_, "/camera/green.jpg").status, 404);
  EXPECT_EQ(http_get(port_, "/camera/green.json").status, 404);
  EXPECT_EQ(http_get(port_, "/camera/%2e%2e%2fred.jpg").status, 404);
  EXPECT_EQ(raw_request(port_, "POST /status.json HTTP/1.1\r\nHost: x\r\nContent-Length: 2\r\n\r\n{}").status, 405);
  EXPECT_EQ(raw_request(port_, "DELETE / HTTP/1.1\r\nHost: x\r\n\r\n").status, 405);
  // Malformed: every one gets a 4xx (or the connection closed without an answer), none a 2xx.
  const std::vector<std::string> malformed = {
      "GARBAGE\r\n\r\n",
      "GET\r\n\r\n",
      "GET / HTTP/9.9\r\n\r\n",
      "GET /status.json HTTP/1.1\r\nHost: x\r\nContent-Length: -5\r\n\r\n",
      "GET /status.json HTTP/1.1\r\nBadHeaderNoColon\r\n\r\n",
      "GET " + std::string(20000, 'a') + " HTTP/1.1\r\n\r\n",
      std::string("GET /\x00\x01\x02 HTTP/1.1\r\n\r\n", 21),  // NULs inside the path
      "GET /status.json HTTP/1.1\r\nHost: x\r\nContent-Length: abc\r\n\r\n",
      "GET /status.json HTTP/1.1\r\nHost: x\r\nContent-Length: 99999999999999999999\r\n\r\n",
  };
#if defined(IPS_SANITIZED)
  // CivetWeb answers what it cannot parse itself, on its own request thread, whose stack size
  // Debian's build fixed at 100 KiB: under ASan its error path (vsnprintf through the
  // sanitizer's interceptors) overflows that stack inside the library. Our handlers run on a
  // default-size stack (server.cpp) and are exercised above; the malformed requests run in the
  // release configuration.
  GTEST_SKIP() << "malformed requests are answered inside CivetWeb on a 100 KiB stack that ASan overflows; "
                  "checked in the release configuration";
#endif
  for (const auto& m : malformed) {
    const auto r = raw_request(port_, m, 3000);
    EXPECT_TRUE(r.status == 0 || (r.status >= 400 && r.status < 500)) << r.status << " for " << m.substr(0, 40);
  }
  // Nothing else happened: the server still answers, and counted the refusals it made itself.
  EXPECT_EQ(http_get(port_, "/status.json").status, 200);
  EXPECT_GE(server_->counters().bad_requests, 7u);
}

TEST_F(WebServerTest, CameraViewDrawsTheDetectionsWhereTheyAre) {
  const auto jpg = http_get(port_, "/camera/red.jpg");
  ASSERT_EQ(jpg.status, 200);
  const auto plain = http_get(port_, "/camera/red.jpg?overlay=0");
  const auto info = nlohmann::json::parse(http_get(port_, "/camera/red.json").body);
  ASSERT_EQ(plain.status, 200);
  EXPECT_EQ(info["camera"], "red");
  EXPECT_EQ(info["width"], 960);
  EXPECT_DOUBLE_EQ(info["scale"].get<double>(), 0.5);
  ASSERT_EQ(info["detections"].size(), 2u);
  const cv::Mat image = cv::imdecode(std::vector<unsigned char>(jpg.body.begin(), jpg.body.end()), cv::IMREAD_COLOR);
  const cv::Mat bare =
      cv::imdecode(std::vector<unsigned char>(plain.body.begin(), plain.body.end()), cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(image.cols, 960);
  ASSERT_EQ(bare.cols, 960);
  // Independent truth: OpenCV's own detector on the served frame finds the markers where the
  // JSON says they are drawn (the corners the "camera thread" handed over, halved).
  std::vector<std::vector<cv::Point2f>> corners;
  std::vector<int> ids;
  cv::aruco::detectMarkers(bare, cv::aruco::getPredefinedDictionary(cv::aruco::DICT_4X4_100), corners, ids);
  ASSERT_EQ(ids.size(), 2u);
  for (const auto& d : info["detections"]) {
    const int id = d["id"];
    const auto k = static_cast<std::size_t>(std::find(ids.begin(), ids.end(), id) - ids.begin());
    ASSERT_LT(k, ids.size()) << id;
    for (int c = 0; c < 4; ++c) {
      EXPECT_NEAR(corners[k][static_cast<std::size_t>(c)].x, d["corners"][c][0].get<double>(), 1.5);
      EXPECT_NEAR(corners[k][static_cast<std::size_t>(c)].y, d["corners"][c][1].get<double>(), 1.5);
    }
    // The outline: the midpoint of each edge is green in the overlay image, grey/white/black
    // in the plain one.
    for (int c = 0; c < 4; ++c) {
      const double x = 0.5 * (d["corners"][c][0].get<double>() + d["corners"][(c + 1) % 4][0].get<double>());
      const double y = 0.5 * (d["corners"][c][1].get<double>() + d["corners"][(c + 1) % 4][1].get<double>());
      const cv::Vec3b px = image.at<cv::Vec3b>(cvRound(y), cvRound(x));
      // Green, clearly (JPEG chroma subsampling blurs a thin line's colour a little).
      EXPECT_GT(px[1] - std::max(px[0], px[2]), 80) << "edge " << c << " of " << id << ": " << px;
    }
  }
  // Away from the markers the overlay leaves the frame alone.
  EXPECT_NEAR(image.at<cv::Vec3b>(500, 100)[1], 200, 12);
  // Rate limit: an immediate second request is the same frame (no new hand-over).
  const std::uint64_t handed = taps_[0]->handed_over();
  EXPECT_EQ(http_get(port_, "/camera/red.jpg").body, jpg.body);
  EXPECT_EQ(taps_[0]->handed_over(), handed);
  // white's camera thread never delivers: 503 after the wait, nothing else happens.
  EXPECT_EQ(http_get(port_, "/camera/white.jpg").status, 503);
}

Datagram update(std::uint32_t n, double x) {
  Datagram d;
  d.update = n;
  d.capture_monotonic_ns = monotonic_ns();
  MarkerRecord m;
  m.id = 5;
  m.camera_mask = 0b11;
  m.x = x;
  m.y = 2.0;
  m.yaw = 0.5;
  d.markers.push_back(m);
  return d;
}

TEST_F(WebServerTest, StreamsRateLimitedUpdatesWithBoundedQueuesAndSurvivesAbruptDisconnects) {
  test::EventStream good(port_);
  test::EventStream stalled(port_);  // connects and never reads
  // The first event of a new client is the latest status.
  auto first = good.next(3000);
  EXPECT_EQ(first.first, "status");
  EXPECT_NE(good.status_line().find("200"), std::string::npos);
  // 2 s of 200 updates/s from the "fusion thread": at most ~50 messages/s reach a client.
  std::thread fusion([this] {
    for (std::uint32_t i = 0; i < 400; ++i) {
      server_->publish(update(i, 1.0 + 0.001 * i));
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });
  int markers = 0;
  double last_x = 0;
  const std::int64_t t0 = monotonic_ns();
  while (monotonic_ns() - t0 < 2'500'000'000) {
    const auto e = good.next(500);
    if (e.first != "markers") continue;
    const auto j = nlohmann::json::parse(e.second);
    // A client that connected before the first update may first get that (empty) state.
    if (j["markers"].empty() && markers == 0) continue;
    EXPECT_EQ(j["markers"].size(), 1u);  // not ASSERT: the fusion thread must still be joined
    if (j["markers"].size() != 1u) continue;
    EXPECT_EQ(j["markers"][0]["id"], 5);
    EXPECT_EQ(j["markers"][0]["cameras"], 3);
    EXPECT_EQ(j["markers"][0]["sources"], nlohmann::json::array({"camera"}));
    EXPECT_EQ(j["markers"][0]["has_yaw"], true);
    EXPECT_GE(j["markers"][0]["x"].get<double>(), last_x);  // the newest state, in order
    last_x = j["markers"][0]["x"];
    ++markers;
  }
  fusion.join();
  EXPECT_GE(markers, 20);   // >= 10 Hz even on a loaded machine
  EXPECT_LE(markers, 140);  // rate-limited: 50 Hz x 2.5 s plus slack, not 400
  EXPECT_NEAR(last_x, 1.399, 0.01);
  // Abrupt disconnects of many clients while updates flow: no crash, the rest keeps going.
  std::vector<std::unique_ptr<test::EventStream>> crowd;
  for (int i = 0; i < 2; ++i) crowd.push_back(std::make_unique<test::EventStream>(port_));
  for (auto& c : crowd) c->next(2000);
  EXPECT_EQ(http_get(port_, "/events").status, 503);  // max_clients = 4: good, stalled + 2
  for (auto& c : crowd) c->socket().reset();
  for (std::uint32_t i = 0; i < 50; ++i) {
    server_->publish(update(400 + i, 2.0));
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  bool got = false;
  for (int i = 0; i < 20 && !got; ++i) {
    const auto e = good.next(500);
    got = e.first == "markers" && nlohmann::json::parse(e.second)["markers"][0]["x"] == 2.0;
  }
  EXPECT_TRUE(got);
  const WebCounters c = server_->counters();
  EXPECT_GE(c.clients_total, 4u);
  EXPECT_GE(c.refused, 1u);
  // The stalled client: its socket buffers hold the first messages; a few hundred bytes each
  // fill them slowly, so its queue need not have overflowed yet; the fan-out never blocked
  // (the good client got everything above). Its disconnect frees its slot.
  stalled.socket().reset();
  for (int i = 0; i < 40 && server_->counters().clients > 1; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_EQ(server_->counters().clients, 1u);
}

// A version-2 update: one body (and one plain marker) at capture time `t` + dt.
Datagram body_update(std::uint32_t n, std::int64_t t, std::int32_t dt_us, double x) {
  Datagram d;
  d.version = 2;
  d.update = n;
  d.capture_monotonic_ns = t;
  MarkerRecord m;
  m.id = 9;
  m.camera_mask = 0b01;
  m.x = 0.5;
  d.markers.push_back(m);
  BodyRecord b;
  b.name = "cart \"7\"";  // any UTF-8 is a body name on the wire; the page must not break on quotes
  b.camera_mask = 0b10;
  b.x = x;
  b.y = 2.5;
  b.z = 0.0;
  b.yaw = 0.3;
  b.qw = std::cos(0.15);
  b.qz = std::sin(0.15);
  b.quality = 1234.5;
  b.spread = 0.004;
  b.dt_us = dt_us;
  b.has_yaw = true;
  b.id_count = 2;
  b.ids = {5, 6};
  b.has_velocity = true;
  b.vx = 0.3;
  b.vy = -0.4;
  d.bodies.push_back(b);
  return d;
}

TEST_F(WebServerTest, StreamsBodiesWithTheirPoseMarkersAndCamerasNeverBackInTime) {
  test::EventStream s(port_);
  const std::int64_t t0 = monotonic_ns();
  server_->publish(body_update(1, t0, 2000, 1.5));
  // A later update whose body was captured before the first one's (a late camera): the body
  // keeps its newer pose; the marker (newer) moves on.
  server_->publish(body_update(2, t0 + 1'000'000, -5000, 9.9));
  nlohmann::json body;
  for (int i = 0; i < 20 && body.is_null(); ++i) {
    const auto e = s.next(1000);
    if (e.first != "markers") continue;
    const auto j = nlohmann::json::parse(e.second);
    if (j["update"] == 2 && j["bodies"].size() == 1u) body = j["bodies"][0];
  }
  ASSERT_FALSE(body.is_null());
  EXPECT_EQ(body["name"], "cart \"7\"");
  EXPECT_EQ(body["x"], 1.5);
  EXPECT_EQ(body["y"], 2.5);
  EXPECT_EQ(body["yaw"], 0.3);
  EXPECT_EQ(body["has_yaw"], true);
  EXPECT_NEAR(body["q"][0].get<double>(), std::cos(0.15), 1e-12);
  EXPECT_NEAR(body["q"][3].get<double>(), std::sin(0.15), 1e-12);
  EXPECT_EQ(body["cameras"], 2);
  EXPECT_EQ(body["ids"], nlohmann::json({5, 6}));
  EXPECT_EQ(body["id_count"], 2);
  EXPECT_EQ(body["t_mono_ns"], t0 + 2'000'000);
  EXPECT_EQ(body["vx"], 0.3);
  EXPECT_EQ(body["vy"], -0.4);
  EXPECT_FALSE(body.contains("yaw_rate"));  // not measured: absent, not 0
  EXPECT_GE(body["age"].get<double>(), -0.01);
  EXPECT_LT(body["age"].get<double>(), 5.0);
  // A newer pose replaces it.
  server_->publish(body_update(3, t0 + 40'000'000, 0, 1.6));
  bool moved = false;
  for (int i = 0; i < 20 && !moved; ++i) {
    const auto e = s.next(1000);
    if (e.first != "markers") continue;
    const auto j = nlohmann::json::parse(e.second);
    moved = j["bodies"].size() == 1u && j["bodies"][0]["x"] == 1.6;
  }
  EXPECT_TRUE(moved);
}

TEST(WebRoute, HeadIsRoutedLikeGetAndOtherMethodsAreRefused) {
  using K = Route::Kind;
  for (const std::string path : {"/", "/status.json", "/layout.json", "/events", "/assets/app.js", "/camera/red.jpg",
                                 "/camera/red.json", "/nope"}) {
    const Route get = route_request("GET", path), head = route_request("HEAD", path);
    EXPECT_EQ(head.kind, get.kind) << path;
    EXPECT_EQ(head.name, get.name) << path;
    EXPECT_TRUE(head.head) << path;
    EXPECT_FALSE(get.head) << path;
  }
  for (const std::string m : {"PUT", "OPTIONS", "head", "TRACE"})
    EXPECT_EQ(route_request(m, "/").kind, K::kBadMethod) << m;
}

TEST(WebConfig, ConnectionLimitsAndTimeoutHaveDefaultsAndRanges) {
  const DaemonConfig d = parse_config(config_with("web: {listen: \"127.0.0.1:8081\"}\n"), "t.yaml");
  EXPECT_EQ(d.web.max_connections, 128);
  EXPECT_EQ(d.web.max_per_address, 8);
  EXPECT_DOUBLE_EQ(d.web.request_timeout_s, 1.5);
  const DaemonConfig c = parse_config(
      config_with(
          "web: {listen: \"127.0.0.1:8081\", max_connections: 300, max_per_address: 3, request_timeout: 2.5}\n"),
      "t.yaml");
  EXPECT_EQ(c.web.max_connections, 300);
  EXPECT_EQ(c.web.max_per_address, 3);
  EXPECT_DOUBLE_EQ(c.web.request_timeout_s, 2.5);
  const std::pair<std::string, std::string> bad[] = {
      {"max_connections: 8", "web.max_connections"},   {"max_connections: 5000", "web.max_connections"},
      {"max_per_address: 0", "web.max_per_address"},   {"request_timeout: 0.05", "web.request_timeout"},
      {"request_timeout: 600", "web.request_timeout"}, {"request_timeout: soon", "web.request_timeout"}};
  for (const auto& [yaml, key] : bad) {
    try {
      parse_config(config_with("web: {listen: \"127.0.0.1:8081\", " + yaml + "}\n"), "t.yaml");
      ADD_FAILURE() << "accepted: " << yaml;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
}

// The value of header `name` in `headers` ("" if absent); names compared case-insensitively.
std::string header(const std::string& headers, std::string name) {
  const auto lower = [](std::string s) {
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
  };
  const std::string h = lower(headers);
  const auto at = h.find("\r\n" + lower(name) + ":");
  if (at == std::string::npos) return "";
  const auto begin = headers.find_first_not_of(' ', at + 3 + name.size());
  return headers.substr(begin, headers.find("\r\n", begin) - begin);
}

TEST_F(WebServerTest, HeadAnswersEveryGetRouteWithItsStatusAndHeadersAndNoBody) {
  ASSERT_EQ(http_get(port_, "/camera/red.jpg").status, 200);  // so that red.json describes a frame
  for (const std::string path : {"/", "/index.html", "/status.json", "/layout.json", "/assets/app.js",
                                 "/assets/style.css", "/camera/red.json", "/nope", "/camera/green.jpg"}) {
    const auto get = http_get(port_, path);
    // Read until the server closes: a body sent after the headers would show up here.
    const auto head = raw_request(port_, "HEAD " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n");
    EXPECT_EQ(head.status, get.status) << path;
    EXPECT_EQ(header(head.headers, "Content-Type"), header(get.headers, "Content-Type")) << path;
    EXPECT_FALSE(header(get.headers, "Content-Type").empty()) << path;
    EXPECT_EQ(header(head.headers, "Content-Length"), std::to_string(get.body.size())) << path;
    EXPECT_EQ(head.body, "") << path;
  }
  const auto status = raw_request(port_, "HEAD /status.json HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(status.status, 200);
  EXPECT_EQ(header(status.headers, "Content-Type"), "application/json");
  // The stream: its headers, then the connection ends (no events, no stream slot taken).
  const auto events = raw_request(port_, "HEAD /events HTTP/1.1\r\nHost: x\r\n\r\n", 3000);
  EXPECT_EQ(events.status, 200);
  EXPECT_EQ(header(events.headers, "Content-Type"), "text/event-stream");
  EXPECT_EQ(events.body, "");
  EXPECT_EQ(server_->counters().clients_total, 0u);
  const auto post = raw_request(port_, "POST / HTTP/1.1\r\nHost: x\r\nContent-Length: 0\r\n\r\n");
  EXPECT_EQ(post.status, 405);
  EXPECT_EQ(header(post.headers, "Allow"), "GET, HEAD");
}

// The lock-out of issue 24: idle TCP connections (accepted, no request) used to hold every
// HTTP thread for 10 s. Now 100 of them, kept open (the server closes an idle one after
// web.request_timeout; it is reopened at once, as a flooding host would), never delay
// /status.json past 1 s.
TEST_F(WebServerTest, AHundredIdleConnectionsNeverDelayStatusJsonPastOneSecond) {
  constexpr int kIdle = 100;
  std::vector<std::unique_ptr<test::TcpClient>> idle;
  for (int i = 0; i < kIdle; ++i) {
    idle.push_back(std::make_unique<test::TcpClient>(port_));
    ASSERT_TRUE(idle.back()->ok()) << i;
  }
  const std::int64_t t0 = monotonic_ns();
  int checks = 0, reopened = 0;
  double slowest = 0;
  while (monotonic_ns() - t0 < 4'000'000'000) {
    const std::int64_t start = monotonic_ns();
    const auto r = http_get(port_, "/status.json", 3000);
    const double s = 1e-9 * static_cast<double>(monotonic_ns() - start);
    slowest = std::max(slowest, s);
    EXPECT_EQ(r.status, 200) << "check " << checks;
    EXPECT_LT(s, 1.0) << "check " << checks << " at " << 1e-9 * static_cast<double>(start - t0) << " s";
    ++checks;
    // Keep the flood at 100: reopen every socket the server closed.
    for (auto& c : idle) {
      std::string ignored;
      if (!c->receive(ignored, 0)) {
        c = std::make_unique<test::TcpClient>(port_);
        ++reopened;
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  idle.clear();  // closes them
  EXPECT_GE(checks, 10);
  // The server closed the idle sockets after request_timeout (1.5 s): within the 4 s, each at
  // least once.
  EXPECT_GE(reopened, kIdle) << "slowest status.json " << slowest << " s";
  EXPECT_EQ(http_get(port_, "/status.json").status, 200);
}

TEST(WebServer, OneAddressGetsAtMostMaxPerAddressRequestsAndStreams) {
  WebConfig c;
  c.host = "127.0.0.1";
  c.port = free_tcp_port();
  c.listen = "127.0.0.1:" + std::to_string(c.port);
  c.max_per_address = 2;
  WebServer server(c, "DICT_4X4_100");
  server.set_status(R"({"type": "ipsd.status"})");
  test::EventStream a(server.port()), b(server.port());
  EXPECT_EQ(a.next(3000).first, "status");
  EXPECT_EQ(b.next(3000).first, "status");
  const auto refused = http_get(server.port(), "/status.json");
  EXPECT_EQ(refused.status, 503);
  EXPECT_NE(refused.body.find("web.max_per_address"), std::string::npos) << refused.body;
  EXPECT_EQ(http_get(server.port(), "/events").status, 503);
  EXPECT_GE(server.counters().limited, 2u);
  EXPECT_GE(server.counters().refused, 1u);
  // A closed stream gives its slot back (noticed at its next write: the keep-alive, <= 1 s).
  a.socket().reset();
  int status = 0;
  for (int i = 0; i < 30 && status != 200; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    status = http_get(server.port(), "/status.json").status;
  }
  EXPECT_EQ(status, 200);
}

TEST(WebServer, ABusyPortIsAnErrorNamingWebListen) {
  WebConfig c;
  c.host = "127.0.0.1";
  c.port = free_tcp_port();
  c.listen = "127.0.0.1:" + std::to_string(c.port);
  WebServer first(c, "DICT_4X4_100");
  try {
    WebServer second(c, "DICT_4X4_100");
    FAIL() << "two servers on one port";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("web.listen"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ips
