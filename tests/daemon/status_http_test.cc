// The status HTTP server (status_http.h): routes, Prometheus text, the HTML page, limits and
// shutdown, over real loopback connections; then the page as a browser renders it (headless
// Chromium: a screenshot that is not blank, and the DOM it built).
#include "fleetmap/daemon/status_http.h"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/core/tcp_stream.hpp>
#include <boost/beast/http.hpp>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "chromedriver_session.h"
#include "expect_error.h"
#include "fleet_processes.h"
#include "fleetmap/interchange/graph_layout.h"
#include "fleetmap/interchange/map_picture.h"
#include "fleetmap/interchange/svg_canvas.h"
#include "fleetmap/repository/channel_registry.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/repository/revision_picture.h"
#include "headless_chromium.h"
#include "image_files.h"
#include "random_robot_map.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = net::ip::tcp;
using Response = http::response<http::string_body>;

constexpr std::int64_t kSecond = 1'000'000'000;
constexpr std::int64_t kRobotSyncNs = 1'714'567'890 * kSecond;  // 2024-05-01T12:51:30Z

FleetStatus FixedStatus() {
  FleetStatus status;
  status.now_ns = kRobotSyncNs + 330 * kSecond;  // 5 min 30 s after the first robot's sync
  status.started_ns = kRobotSyncNs - 3 * 3600 * kSecond;
  status.listen = "127.0.0.1:7420";
  status.head_revision = 7;
  status.map_nodes = 1234;
  status.map_edges = 2345;
  status.map_paths = 12;
  status.map_landmark_bytes = 5'400'000;
  status.robots = {
      {.name = "<r&d>",
       .uuid = "0b7e2d6c-1f4a-4c2e-9d3b-5a6f7e8d9c01",
       .last_sync_ns = kRobotSyncNs,
       .added_ns = kRobotSyncNs - 86400 * kSecond,
       .pushes = 4,
       .downloads = 2,
       .channel = "head",
       .installed_revision = 0,
       .sent_revision = 0,
       .channel_revision = 7,
       .behind_known = false,
       .behind = 0,
       .map_differs = false,
       .last_error = "",
       .last_error_ns = 0},
      {.name = "scout \"two\"",
       .uuid = "0b7e2d6c-1f4a-4c2e-9d3b-5a6f7e8d9c02",
       .last_sync_ns = kRobotSyncNs - kSecond / 2,
       .added_ns = kRobotSyncNs - 86400 * kSecond,
       .pushes = 1,
       .downloads = 9,
       .channel = "stable",
       .installed_revision = 5,
       .sent_revision = 5,
       .channel_revision = 7,
       .behind_known = true,
       .behind = 2,
       .map_differs = true,
       .last_error = "agent: <disk full>",
       .last_error_ns = kRobotSyncNs - kSecond},
  };
  status.channels = {{"stable", 7}};
  status.queue_length = 2;
  status.merging = MergingSubmission{"5c0ffee0-0000-4000-8000-000000000042", "<r&d>", kRobotSyncNs};
  status.pushes = 5;
  status.downloads = 11;
  status.merges = 6;
  status.merges_failed = 1;
  status.sessions_total = 40;
  status.sessions_open = 3;
  status.bytes_received = 123'456'789;
  status.bytes_sent = 98'765;
  status.errors_by_code = {{"BAD_TOKEN", 3}, {"FRAME_TOO_LARGE", 1}};
  return status;
}

// A keep-alive HTTP/1.1 client on loopback; every exchange is bounded by a 10 s deadline.
class TestClient {
 public:
  explicit TestClient(std::uint16_t port) : stream_(io_) {
    stream_.expires_after(std::chrono::seconds(10));
    beast::error_code connect_error = net::error::would_block;
    stream_.async_connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port),
                          [&](beast::error_code ec) { connect_error = ec; });
    io_.run();
    if (connect_error) throw std::runtime_error("connect: " + connect_error.message());
  }

  // Sends `request` and reads the response; nullopt when the connection failed or closed.
  std::optional<Response> Exchange(http::request<http::string_body> request) {
    request.set(http::field::host, "127.0.0.1");
    request.prepare_payload();
    std::optional<Response> result;
    Response response;
    stream_.expires_after(std::chrono::seconds(10));
    http::async_write(stream_, request, [&](beast::error_code write_error, std::size_t) {
      if (write_error) return;
      http::async_read(stream_, buffer_, response, [&](beast::error_code read_error, std::size_t) {
        if (!read_error) result = std::move(response);
      });
    });
    io_.restart();
    io_.run();
    return result;
  }

  std::optional<Response> Get(const std::string& target) {
    return Exchange({http::verb::get, target, 11});
  }

 private:
  net::io_context io_;
  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
};

Response MustGet(std::uint16_t port, const std::string& target) {
  TestClient client(port);
  auto response = client.Get(target);
  if (!response) throw std::runtime_error("no response to GET " + target);
  return *response;
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

bool HasLine(const std::vector<std::string>& lines, const std::string& line) {
  return std::find(lines.begin(), lines.end(), line) != lines.end();
}

std::size_t Count(const std::string& text, const std::string& what) {
  std::size_t count = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++count;
  return count;
}

// The part of `html` inside <table id="robots">...</table>.
std::string RobotsTable(const std::string& html) {
  const auto begin = html.find("<table id=\"robots\"");
  if (begin == std::string::npos) return "";
  const auto end = html.find("</table>", begin);
  return html.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
}

// FixedStatus with the head's picture (a real one, of a small map) and three revisions.
FleetStatus StatusWithPictureAndHistory() {
  FleetStatus status = FixedStatus();
  const GraphBatch map = testing::RandomRobotMap(Uuid::Generate(), 6, 3, 10);
  SvgCanvas canvas("the head");
  MapPicture::Compose(GraphLayout::Compute(map.nodes, map.edges), map.edges, {}).Draw(canvas);
  status.head_picture_svg = std::make_shared<const std::string>(canvas.svg());
  status.picture_revision = 6;  // the head (7) is still being drawn
  status.recent_revisions = {
      {7, "revert", "ops", "", kRobotSyncNs, 0, 4, "of revision 6"},
      {6, "merge", "<r&d>", "<r&d>", kRobotSyncNs - 600 * kSecond, 12, 0, ""},
      {5, "merge", "scout", "0b7e2d6c-1f4a-4c2e-9d3b-5a6f7e8d9c02", kRobotSyncNs - 7200 * kSecond,
       4, 0, ""},
  };
  return status;
}

// The part of `html` inside <table id="history">...</table>.
std::string HistoryTable(const std::string& html) {
  const auto begin = html.find("<table id=\"history\"");
  if (begin == std::string::npos) return "";
  const auto end = html.find("</table>", begin);
  return html.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
}

class StatusHttpTest : public ::testing::Test {
 protected:
  StatusHttpServer server_{"127.0.0.1:0", [] { return FixedStatus(); }};
};

TEST_F(StatusHttpTest, ReportsTheBoundEphemeralPort) {
  EXPECT_NE(server_.port(), 0);
  EXPECT_EQ(server_.address(), "127.0.0.1:" + std::to_string(server_.port()));
}

TEST_F(StatusHttpTest, MetricsAreThePrometheusTextFormat) {
  const Response response = MustGet(server_.port(), "/metrics");
  EXPECT_EQ(response.result(), http::status::ok);
  EXPECT_EQ(std::string(response[http::field::content_type]),
            "text/plain; version=0.0.4; charset=utf-8");
  const auto lines = Lines(response.body());
  for (const char* expected : {
           "# HELP fleetmap_revision Head revision of the fleet map.",
           "# TYPE fleetmap_revision gauge",
           "fleetmap_revision 7",
           "fleetmap_robots 2",
           "fleetmap_map_nodes 1234",
           "fleetmap_map_edges 2345",
           "fleetmap_map_landmark_bytes 5400000",
           "fleetmap_merge_queue_length 2",
           "fleetmap_merge_running 1",
           "# TYPE fleetmap_pushes_total counter",
           "fleetmap_pushes_total 5",
           "fleetmap_downloads_total 11",
           "fleetmap_merges_total 6",
           "fleetmap_sessions_open 3",
           "fleetmap_bytes_received_total 123456789",
           "fleetmap_bytes_sent_total 98765",
           "# TYPE fleetmap_errors_total counter",
           "fleetmap_errors_total{code=\"bad_token\"} 3",
           "fleetmap_errors_total{code=\"frame_too_large\"} 1",
           "# TYPE fleetmap_robot_last_sync_timestamp_seconds gauge",
           "fleetmap_robot_last_sync_timestamp_seconds{robot=\"<r&d>\","
           "robot_id=\"0b7e2d6c-1f4a-4c2e-9d3b-5a6f7e8d9c01\"} 1714567890",
           // Label values escape the double quote; a half second survives the conversion.
           "fleetmap_robot_last_sync_timestamp_seconds{robot=\"scout \\\"two\\\"\","
           "robot_id=\"0b7e2d6c-1f4a-4c2e-9d3b-5a6f7e8d9c02\"} 1714567889.5",
           "fleetmap_robot_pushes_total{robot=\"<r&d>\","
           "robot_id=\"0b7e2d6c-1f4a-4c2e-9d3b-5a6f7e8d9c01\"} 4",
           // What each runs; "behind" only where it is known.
           "fleetmap_robot_installed_revision{robot=\"scout \\\"two\\\"\","
           "robot_id=\"0b7e2d6c-1f4a-4c2e-9d3b-5a6f7e8d9c02\",channel=\"stable\"} 5",
           "fleetmap_robot_installed_revision{robot=\"<r&d>\","
           "robot_id=\"0b7e2d6c-1f4a-4c2e-9d3b-5a6f7e8d9c01\",channel=\"head\"} 0",
           "fleetmap_robot_behind_revisions{robot=\"scout \\\"two\\\"\","
           "robot_id=\"0b7e2d6c-1f4a-4c2e-9d3b-5a6f7e8d9c02\",channel=\"stable\"} 2",
           "fleetmap_robot_map_differs{robot=\"scout \\\"two\\\"\","
           "robot_id=\"0b7e2d6c-1f4a-4c2e-9d3b-5a6f7e8d9c02\"} 1",
           "fleetmap_robot_map_differs{robot=\"<r&d>\","
           "robot_id=\"0b7e2d6c-1f4a-4c2e-9d3b-5a6f7e8d9c01\"} 0",
           "fleetmap_channel_revision{channel=\"stable\"} 7",
       }) {
    EXPECT_TRUE(HasLine(lines, expected)) << "missing line: " << expected << "\nin:\n"
                                          << response.body();
  }
  EXPECT_EQ(Count(response.body(), "fleetmap_robot_behind_revisions{"), 1u)
      << "a robot without an installed revision has no behind sample";
  // Every sample belongs to a family announced by HELP and TYPE before it.
  std::string family;
  for (const std::string& line : lines) {
    ASSERT_FALSE(line.empty());
    if (line.rfind("# TYPE ", 0) == 0) {
      family = line.substr(7, line.find(' ', 7) - 7);
    } else if (line[0] != '#') {
      const std::string name = line.substr(0, line.find_first_of("{ "));
      EXPECT_EQ(name, family) << line;
      EXPECT_EQ(name.rfind("fleetmap_", 0), 0u) << line;
    }
  }
  EXPECT_EQ(response.body().back(), '\n');
}

TEST_F(StatusHttpTest, PageShowsTheFactsWithRobotStringsEscaped) {
  const Response response = MustGet(server_.port(), "/");
  EXPECT_EQ(response.result(), http::status::ok);
  EXPECT_EQ(std::string(response[http::field::content_type]), "text/html; charset=utf-8");
  const std::string& html = response.body();
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(html.find("&lt;r&amp;d&gt;"), std::string::npos);
  EXPECT_EQ(html.find("<r&d>"), std::string::npos) << "unescaped robot name in the page";
  EXPECT_NE(html.find("scout &quot;two&quot;"), std::string::npos);
  // Self-contained: one inline script, no external script or other asset (a depot network has
  // no internet).
  EXPECT_EQ(Count(html, "<script"), 1u);
  EXPECT_EQ(html.find("<script src"), std::string::npos);
  EXPECT_EQ(html.find("<link"), std::string::npos);
  EXPECT_EQ(html.find("http://"), std::string::npos);
  EXPECT_EQ(html.find("https://"), std::string::npos);

  const std::string table = RobotsTable(html);
  ASSERT_FALSE(table.empty()) << html;
  EXPECT_EQ(Count(table, "<tr"), 3u) << "one header row and one row per robot:\n" << table;
  EXPECT_EQ(Count(table, "</th>"), 11u);
  // What each runs: the second robot is two behind its channel and its map
  // is flagged; its error is escaped like everything a robot says.
  EXPECT_NE(table.find("data-revision=\"5\">5</td>"), std::string::npos) << table;
  EXPECT_NE(table.find("data-behind=\"2\""), std::string::npos) << table;
  EXPECT_EQ(Count(table, "MAP DIFFERS"), 1u) << table;
  EXPECT_NE(table.find("agent: &lt;disk full&gt;"), std::string::npos) << table;
  EXPECT_NE(html.find("<table id=\"channels\">"), std::string::npos);
  EXPECT_NE(table.find("0b7e2d6c-1f4a-4c2e-9d3b-5a6f7e8d9c01"), std::string::npos);
  EXPECT_NE(table.find("2024-05-01T12:51:30Z"), std::string::npos);
  EXPECT_NE(table.find("5 min ago"), std::string::npos);
  // The summary: revision and map size.
  EXPECT_NE(html.find(">7</div>"), std::string::npos);
  EXPECT_NE(html.find(">1234</div>"), std::string::npos);
  EXPECT_NE(html.find("BAD_TOKEN × 3"), std::string::npos);
}

TEST(StatusHttpServerTest, PageShowsTheHeadsPictureAndTheHistory) {
  const FleetStatus status = StatusWithPictureAndHistory();
  StatusHttpServer server("127.0.0.1:0", [&status] { return status; });
  const Response page = MustGet(server.port(), "/");
  const std::string& html = page.body();
  // The picture's address names its revision, so a browser fetches each revision's once.
  EXPECT_NE(html.find("<img src=\"/map.svg?r=6\""), std::string::npos) << html;
  EXPECT_NE(html.find("(revision 7 is being drawn)"), std::string::npos);
  const std::string history = HistoryTable(html);
  ASSERT_FALSE(history.empty()) << html;
  EXPECT_EQ(Count(history, "<tr>"), 4u) << "a header row and one row per revision:\n" << history;
  EXPECT_NE(history.find("&lt;r&amp;d&gt;"), std::string::npos);
  EXPECT_EQ(history.find("<r&d>"), std::string::npos) << "unescaped author in the page";
  EXPECT_NE(history.find("2024-05-01T12:41:30Z"), std::string::npos) << history;
  EXPECT_NE(history.find("15 min ago"), std::string::npos) << history;
  EXPECT_LT(history.find(">7</td>"), history.find(">6</td>")) << "newest first";
  EXPECT_NE(history.find("<td>revert <span class=\"of\">of revision 6</span></td>"),
            std::string::npos)
      << "a revert names what it undid:\n"
      << history;

  const Response picture = MustGet(server.port(), "/map.svg?r=6");
  EXPECT_EQ(picture.result(), http::status::ok);
  EXPECT_EQ(std::string(picture[http::field::content_type]), "image/svg+xml");
  EXPECT_EQ(picture.body(), *status.head_picture_svg);
}

TEST_F(StatusHttpTest, BeforeTheFirstPictureIsDrawnThePageSaysSoAndMapSvgIs503) {
  EXPECT_NE(MustGet(server_.port(), "/").body().find("The picture of revision 7 is being drawn"),
            std::string::npos);
  EXPECT_EQ(MustGet(server_.port(), "/map.svg").result(), http::status::service_unavailable);
}

TEST_F(StatusHttpTest, HealthzSaysOk) {
  const Response response = MustGet(server_.port(), "/healthz");
  EXPECT_EQ(response.result(), http::status::ok);
  EXPECT_EQ(response.body(), "ok");
}

TEST_F(StatusHttpTest, UnknownPathIs404AndOtherMethodsAre405) {
  EXPECT_EQ(MustGet(server_.port(), "/nope").result(), http::status::not_found);
  EXPECT_EQ(MustGet(server_.port(), "/metrics/extra").result(), http::status::not_found);
  EXPECT_EQ(MustGet(server_.port(), "/metrics?debug=1").result(), http::status::ok);

  TestClient client(server_.port());
  auto post = client.Exchange({http::verb::post, "/", 11});
  ASSERT_TRUE(post.has_value());
  EXPECT_EQ(post->result(), http::status::method_not_allowed);
  EXPECT_EQ(std::string((*post)[http::field::allow]), "GET");
  auto put = client.Exchange({http::verb::put, "/metrics", 11});
  ASSERT_TRUE(put.has_value()) << "a 405 keeps the connection alive";
  EXPECT_EQ(put->result(), http::status::method_not_allowed);
}

TEST_F(StatusHttpTest, KeepAliveServesSeveralRequestsOnOneConnection) {
  TestClient client(server_.port());
  for (const char* target : {"/healthz", "/metrics", "/", "/healthz"}) {
    auto response = client.Get(target);
    ASSERT_TRUE(response.has_value()) << target;
    EXPECT_EQ(response->result(), http::status::ok) << target;
    EXPECT_TRUE(response->keep_alive()) << target;
  }
}

TEST_F(StatusHttpTest, OversizedBodyIsRefusedWith413) {
  TestClient client(server_.port());
  http::request<http::string_body> request{http::verb::post, "/", 11};
  request.body() = std::string(64 * 1024, 'x');
  auto response = client.Exchange(request);
  ASSERT_TRUE(response.has_value());
  EXPECT_EQ(response->result(), http::status::payload_too_large);
  EXPECT_FALSE(response->keep_alive());
}

TEST(StatusHttpServerTest, AFailingStatusSourceGives500WithTheReason) {
  StatusHttpServer server("127.0.0.1:0",
                          []() -> FleetStatus { throw std::runtime_error("repository closed"); });
  const Response response = MustGet(server.port(), "/metrics");
  EXPECT_EQ(response.result(), http::status::internal_server_error);
  EXPECT_NE(response.body().find("repository closed"), std::string::npos);
  EXPECT_EQ(MustGet(server.port(), "/healthz").result(), http::status::ok);
}

TEST(StatusHttpServerTest, StopClosesIdleKeepAliveConnectionsPromptly) {
  auto server = StartStatusHttp("127.0.0.1:0", [] { return FixedStatus(); });
  TestClient idle(server->port());
  ASSERT_TRUE(idle.Get("/healthz").has_value());

  const auto start = std::chrono::steady_clock::now();
  server->Stop();
  const auto took = std::chrono::steady_clock::now() - start;
  EXPECT_LT(took, std::chrono::seconds(2)) << "an idle connection must not hold up Stop()";
  EXPECT_FALSE(idle.Get("/healthz").has_value()) << "the connection should be closed";
  server->Stop();  // idempotent
}

// Connections that connect and send nothing, as many as the server holds and more: each new
// one pushes out the one that has waited longest for a request, and the rest go after the
// request deadline, so /metrics answers at once whatever they do.
TEST_F(StatusHttpTest, IdleConnectionsDoNotKeepMetricsFromAScraper) {
  for (const int idle_count : {64, 200}) {
    net::io_context io;
    std::vector<tcp::socket> idle;
    for (int i = 0; i < idle_count; ++i) {
      idle.emplace_back(io).connect(
          tcp::endpoint(net::ip::make_address("127.0.0.1"), server_.port()));
    }
    const auto start = std::chrono::steady_clock::now();
    const Response metrics = MustGet(server_.port(), "/metrics");
    const auto took = std::chrono::steady_clock::now() - start;
    EXPECT_EQ(metrics.result(), http::status::ok) << idle_count;
    EXPECT_LT(took, std::chrono::seconds(1)) << idle_count << " idle connections";
    std::printf("/metrics beside %d idle connections: %.1f ms\n", idle_count,
                std::chrono::duration<double, std::milli>(took).count());
  }
}

// A connection that sends part of a request and stops is closed after the request deadline
// (3 s), not kept for as long as it cares to trickle.
TEST_F(StatusHttpTest, APartialRequestIsClosedAfterTheRequestDeadline) {
  net::io_context io;
  tcp::socket socket(io);
  socket.connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), server_.port()));
  net::write(socket, net::buffer(std::string("GET /metrics HTTP/1.1\r\nHost: x\r\n")));
  const auto start = std::chrono::steady_clock::now();
  std::array<char, 64> byte{};
  beast::error_code ec;
  // Bounded: SO_RCVTIMEO of 10 s on a blocking read.
  const timeval ten_s{10, 0};
  ::setsockopt(socket.native_handle(), SOL_SOCKET, SO_RCVTIMEO, &ten_s, sizeof ten_s);
  socket.read_some(net::buffer(byte), ec);
  const auto took = std::chrono::steady_clock::now() - start;
  EXPECT_TRUE(ec == net::error::eof || ec == net::error::connection_reset) << ec.message();
  EXPECT_LT(took, std::chrono::seconds(5));
  EXPECT_GT(took, std::chrono::seconds(2));
}

TEST(StatusHttpServerTest, BadAddressesAreRefused) {
  const auto source = [] { return FleetStatus{}; };
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { StatusHttpServer("127.0.0.1", source); }, "HOST:PORT");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { StatusHttpServer("127.0.0.1:99999", source); },
      "127.0.0.1:99999");
  ExpectError(ErrorCode::kInvalidArgument, [&] { StatusHttpServer("127.0.0.1:http", source); });
  StatusHttpServer taken("127.0.0.1:0", source);
  ExpectError(
      ErrorCode::kBackend,
      [&] { StatusHttpServer("127.0.0.1:" + std::to_string(taken.port()), source); }, "bind");
}

// ---- The page in a browser ----

TEST_F(StatusHttpTest, ChromiumRendersAPageThatIsNotBlank) {
  ScratchDir scratch("fleetmap-status-page");
  const auto png = scratch / "status-page.png";
  RunChromium(scratch, "--screenshot=" + png.string(),
              "http://127.0.0.1:" + std::to_string(server_.port()) + "/");
  ASSERT_TRUE(std::filesystem::exists(png)) << "no screenshot at " << png;
  if (const char* keep = std::getenv("FLEETMAP_STATUS_PAGE_PNG")) {
    std::filesystem::copy_file(png, keep, std::filesystem::copy_options::overwrite_existing);
  }
  const cv::Mat gray = testing::ReadImageFile(png, ImagePixels::kGray8);
  ASSERT_FALSE(gray.empty()) << "the screenshot does not decode: " << png;
  EXPECT_EQ(gray.cols, 1200);
  EXPECT_EQ(gray.rows, 800);
  std::vector<int> histogram(256, 0);
  for (int y = 0; y < gray.rows; ++y) {
    for (int x = 0; x < gray.cols; ++x) ++histogram[gray.at<std::uint8_t>(y, x)];
  }
  const int levels = static_cast<int>(
      std::count_if(histogram.begin(), histogram.end(), [](int count) { return count > 0; }));
  const int background = *std::max_element(histogram.begin(), histogram.end());
  // Text, a header bar, cards and a table: many gray levels (anti-aliased text) and far from
  // one flat colour. A blank or error page has a handful of levels and one dominant one.
  EXPECT_GT(levels, 32) << "distinct gray levels in the screenshot";
  EXPECT_LT(background, gray.rows * gray.cols * 9 / 10) << "one colour covers over 90%";
}

TEST_F(StatusHttpTest, ChromiumBuildsTheRobotsTable) {
  ScratchDir scratch("fleetmap-status-dom");
  const std::string dom = RunChromium(scratch, "--dump-dom",
                                      "http://127.0.0.1:" + std::to_string(server_.port()) + "/");
  const std::string table = RobotsTable(dom);
  ASSERT_FALSE(table.empty()) << "no robots table in the DOM:\n" << dom.substr(0, 4000);
  const auto body = table.find("<tbody>");
  ASSERT_NE(body, std::string::npos) << table;
  EXPECT_EQ(Count(table.substr(body), "<tr"), 2u) << "one body row per robot:\n" << table;
  // The DOM serializer escapes <, > and & in text, as the page did; quotes in text stay plain.
  EXPECT_NE(table.find("&lt;r&amp;d&gt;"), std::string::npos) << table;
  EXPECT_NE(table.find("scout \"two\""), std::string::npos) << table;
}

// A real fleetmapd after a real agent's push made revision 1: the page in Chromium shows the
// head's picture and the history row of that revision, the picture itself renders in
// Chromium with coloured nodes, and the screenshot of the page is not blank.
TEST(StatusPageInChromiumTest, ShowsTheHeadsPictureAndHistoryAfterAPush) {
  ScratchDir scratch("fleetmap-status-push");
  const std::string store = "sqlite:" + (scratch / "fleet.db").string();
  GraphStore::Open(store);  // created and migrated before the robot is registered in it
  const testing::TestRobot robot = testing::RegisterRobot(store, "scout-1", scratch / "robot");
  testing::WriteLocalMap(robot, testing::RandomRobotMap(robot.id, 8, 5, 20));
  // Never relaxed here: the picture says its layout is composed.
  testing::Fleetmapd server = testing::StartFleetmapd(
      store, scratch / "fleetmapd.log", {"--http", "127.0.0.1:0", "--picture-relax-nodes", "0"});
  ASSERT_FALSE(server.address.empty());
  const std::optional<std::string> line =
      server.process->ReadLineContaining("http on", std::chrono::milliseconds(10'000));
  ASSERT_TRUE(line.has_value()) << server.Log();
  const std::string http_address = line->substr(line->rfind(' ') + 1);
  const std::uint16_t port =
      static_cast<std::uint16_t>(std::stoi(http_address.substr(http_address.rfind(':') + 1)));

  const auto agent = testing::StartSync(robot, server.address, scratch / "agent.log");
  const testing::SyncOutcome synced = testing::FinishSync(*agent, scratch / "agent.log");
  ASSERT_EQ(synced.exit, 0);

  // The merge made revision 1; its picture is drawn off the HTTP thread, so wait (bounded).
  std::string svg;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline) {
    const Response picture = MustGet(port, "/map.svg");
    if (picture.result() == http::status::ok &&
        picture.body().find("revision 1 (the head)") != std::string::npos) {
      svg = picture.body();
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_FALSE(svg.empty()) << "no picture of revision 1 within 20 s\n" << server.Log();
  EXPECT_EQ(Count(svg, "<circle"), 8u) << "one disc per node";
  EXPECT_NE(svg.find("revision 1 (the head), composed layout"), std::string::npos) << svg;

  const std::string url = "http://127.0.0.1:" + std::to_string(port) + "/";
  const std::string dom = RunChromium(scratch, "--dump-dom", url);
  // The explorer shows revision 1 (as the server's <img>, or the SVG the script put inline).
  EXPECT_NE(dom.find("id=\"explorer\" data-kind=\"map\" data-revision=\"1\""), std::string::npos)
      << dom.substr(0, 4000);
  const std::string history = HistoryTable(dom);
  ASSERT_FALSE(history.empty()) << dom.substr(0, 4000);
  const auto body = history.find("<tbody>");
  ASSERT_NE(body, std::string::npos) << history;
  EXPECT_EQ(Count(history.substr(body), "<tr>"), 1u) << "one row for revision 1:\n" << history;
  EXPECT_NE(history.find("scout-1"), std::string::npos) << history;
  EXPECT_NE(history.find(">merge<"), std::string::npos) << history;
  EXPECT_NE(history.find(">8</td>"), std::string::npos) << "8 nodes added:\n" << history;

  // The page's screenshot is not blank, and the picture, rendered by Chromium on its own,
  // shows coloured nodes (the rest of the picture is white and greys).
  const auto page_png = scratch / "page.png";
  RunChromium(scratch, "--screenshot=" + page_png.string(), url);
  const cv::Mat page = testing::ReadImageFile(page_png, ImagePixels::kGray8);
  ASSERT_FALSE(page.empty()) << "the screenshot does not decode: " << page_png;
  std::vector<int> histogram(256, 0);
  for (int y = 0; y < page.rows; ++y) {
    for (int x = 0; x < page.cols; ++x) ++histogram[page.at<std::uint8_t>(y, x)];
  }
  EXPECT_GT(std::count_if(histogram.begin(), histogram.end(), [](int n) { return n > 0; }), 32);
  const auto map_png = scratch / "map.png";
  RunChromium(scratch, "--screenshot=" + map_png.string(), url + "map.svg");
  const cv::Mat map = testing::ReadImageFile(map_png, ImagePixels::kBgr8);
  ASSERT_FALSE(map.empty()) << "the screenshot does not decode: " << map_png;
  int coloured = 0;
  for (int y = 0; y < map.rows; ++y) {
    for (int x = 0; x < map.cols; ++x) {
      const cv::Vec3b px = map.at<cv::Vec3b>(y, x);
      coloured += std::max({px[0], px[1], px[2]}) - std::min({px[0], px[1], px[2]}) > 80;
    }
  }
  EXPECT_GT(coloured, 8 * 15) << "the nodes' discs (and the legend's colour bar)";
}

// The fleetmapd behind a status-page browser test: a store with a robot's two pushes merged
// (revisions 1 and 2) and the channel "stable" at revision 1, and the status server's port.
struct ExploredFleet {
  std::string store;
  testing::Fleetmapd server;
  std::uint16_t port = 0;
  std::string robot_name = "scout-1";
};

ExploredFleet StartExploredFleet(const ScratchDir& scratch) {
  ExploredFleet fleet{"sqlite:" + (scratch / "fleet.db").string(), {}, 0};
  GraphStore::Open(fleet.store);
  const testing::TestRobot robot =
      testing::RegisterRobot(fleet.store, fleet.robot_name, scratch / "robot");
  fleet.server =
      testing::StartFleetmapd(fleet.store, scratch / "fleetmapd.log", {"--http", "127.0.0.1:0"});
  if (fleet.server.address.empty()) return fleet;
  const std::optional<std::string> line =
      fleet.server.process->ReadLineContaining("http on", std::chrono::milliseconds(10'000));
  if (!line) return fleet;
  fleet.port = static_cast<std::uint16_t>(std::stoi(line->substr(line->rfind(':') + 1)));
  const GraphBatch first = testing::RandomRobotMap(robot.id, 8, 5, 20);
  for (const GraphBatch& map :
       {first, testing::RandomChainFrom(robot.id, first.nodes.back().id, 6, 6, 20)}) {
    testing::WriteLocalMap(robot, map);
    const auto agent = testing::StartSync(robot, fleet.server.address, scratch / "agent.log",
                                          {"--wait-merge", "--merge-timeout", "60"});
    const testing::SyncOutcome synced = testing::FinishSync(*agent, scratch / "agent.log");
    if (synced.exit != 0) return fleet;
  }
  const std::unique_ptr<Repository> repository = Repository::Open(fleet.store);
  ChannelRegistry(*repository).Set("stable", 1, "ops", "known good", 1'700'000'000'000'000'000);
  // The status reads channels from the store every few seconds, and the head's picture is
  // drawn off the HTTP thread after the merge: wait (bounded) for both.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < deadline) {
    if (MustGet(fleet.port, "/").body().find("href=\"/?r=1\"") != std::string::npos &&
        MustGet(fleet.port, "/map.svg?r=2").result() == http::status::ok) {
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  return fleet;
}

// The explorer in real Chromium, driven by ChromeDriver as a user would: the map zooms on a
// button and on the wheel (its viewBox changes), a click on a node shows that node's outing,
// robot, time of day and revision as the store has them, the channel's link shows the
// channel's revision, and a history row's link shows what its revision changed, counted as
// the revision's merge recorded it.
constexpr const char* kMapReady =
    "const m = document.getElementById('map'); return !!m && m.dataset.ready !== undefined;";

// The width of an SVG viewBox ("x y w h").
double ViewBoxWidth(const nlohmann::json& box) {
  std::istringstream in(box.get<std::string>());
  double x = 0, y = 0, w = 0;
  in >> x >> y >> w;
  return w;
}

// Zoom: a button, then the wheel over the map; each changes the viewBox, narrower; reset.
void ExpectTheMapZooms(testing::ChromeDriverSession& browser) {
  const std::string view_box = "return document.querySelector('#map svg').getAttribute('viewBox');";
  const nlohmann::json whole = browser.Run(view_box);
  browser.Click("#zoom-in");
  const nlohmann::json zoomed = browser.Run(view_box);
  EXPECT_NE(zoomed, whole);
  EXPECT_LT(ViewBoxWidth(zoomed), ViewBoxWidth(whole) * 0.9);
  browser.Wheel("#map svg", -300);
  ASSERT_TRUE(browser.WaitFor(
      "return document.querySelector('#map svg').getAttribute('viewBox') !== " + zoomed.dump() +
          ";",
      std::chrono::seconds(5)));
  EXPECT_LT(ViewBoxWidth(browser.Run(view_box)), ViewBoxWidth(zoomed) * 0.9);
  browser.Click("#zoom-reset");
  EXPECT_EQ(ViewBoxWidth(browser.Run(view_box)), ViewBoxWidth(whole));
}

// A node's facts on a click on the last disc, as the store has that node.
void ExpectAClickedNodesFacts(testing::ChromeDriverSession& browser, Repository& repository,
                              const std::string& robot_name) {
  ASSERT_EQ(browser.Run("return document.querySelectorAll('#map #nodes circle').length;"), 14);
  browser.Click("#map #nodes circle:last-of-type");
  ASSERT_TRUE(browser.WaitFor("return !!document.getElementById('node-details').dataset.node;",
                              std::chrono::seconds(5)));
  const Uuid clicked =
      Uuid::Parse(browser.Run("return document.getElementById('node-details').dataset.node;")
                      .get<std::string>());
  const auto field = [&](const std::string& name) {
    return browser
        .Run("return document.querySelector('#node-details dd[data-field=\"" + name +
             "\"]').textContent;")
        .get<std::string>();
  };
  std::optional<Node> node;
  for (const Node& n : repository.versions().NodesAt(2, false)) {
    if (n.id == clicked) node = n;
  }
  ASSERT_TRUE(node.has_value()) << clicked.ToString();
  EXPECT_EQ(field("robot"), robot_name);
  EXPECT_EQ(field("outing"), node->outing.ToString());
  const std::time_t captured = static_cast<std::time_t>(node->stamp_ns / 1'000'000'000);
  std::tm utc{};
  gmtime_r(&captured, &utc);
  char iso[32];
  std::strftime(iso, sizeof iso, "%Y-%m-%dT%H:%M:%SZ", &utc);
  EXPECT_EQ(field("captured"), iso);
  EXPECT_EQ(field("time of day"), std::string(iso).substr(11, 5) + " UTC");
  EXPECT_EQ(field("revision"), "r" + std::to_string(NodesAddedBy(repository, 2).at(clicked)));
}

// What revision 2 changed, from its history row: its added nodes coloured, as many as its
// merge recorded, none hidden, the rest grey, its stand-ins squared.
void ExpectRevisionTwosChange(testing::ChromeDriverSession& browser, Repository& repository) {
  browser.Click("#history a.change[href=\"/?change=2\"]");
  ASSERT_TRUE(browser.WaitFor(
      "const e = document.getElementById('explorer'); return !!e && e.dataset.kind === 'change' "
      "&& document.getElementById('map').dataset.ready !== undefined;",
      std::chrono::seconds(30)));
  const Revision second = *repository.inspect().FindRevision(2);
  const auto filled = [&](Rgb colour) {
    char hex[8];
    std::snprintf(hex, sizeof hex, "#%02x%02x%02x", colour.r, colour.g, colour.b);
    return browser.Run("return document.querySelectorAll('#map #nodes circle[fill=\"" +
                       std::string(hex) + "\"]').length;");
  };
  EXPECT_EQ(filled(MapPicture::kAddedNode), second.nodes_added);
  EXPECT_EQ(second.nodes_added, 6);
  EXPECT_EQ(filled(MapPicture::kHiddenNode), second.nodes_hidden);
  EXPECT_EQ(filled(MapPicture::kUnchangedNode), 8);
  // The squares: one per node standing in for a node the merge omitted (its report's count).
  std::set<Uuid> standing_in;
  for (const NodeStandIn& s : repository.versions().StandInsOf(2)) standing_in.insert(s.stand_in);
  EXPECT_EQ(browser.Run("return document.querySelectorAll('#map #stand-ins rect').length;"),
            standing_in.size());
  EXPECT_EQ(nlohmann::json::parse(second.report).at("stand_ins"),
            repository.versions().StandInsOf(2).size());
}

TEST(StatusPageInChromiumTest, TheMapZoomsExplainsANodeShowsAChannelAndWhatARevisionChanged) {
  ScratchDir scratch("fleetmap-status-explore");
  ExploredFleet fleet = StartExploredFleet(scratch);
  ASSERT_NE(fleet.port, 0) << fleet.server.Log();
  const std::unique_ptr<Repository> repository = Repository::Open(fleet.store);
  ASSERT_EQ(repository->Head(), 2) << fleet.server.Log();
  const std::string url = "http://127.0.0.1:" + std::to_string(fleet.port) + "/";
  testing::ChromeDriverSession browser(scratch);
  browser.Navigate(url);
  ASSERT_TRUE(browser.WaitFor(kMapReady, std::chrono::seconds(30))) << fleet.server.Log();
  EXPECT_EQ(browser.Run("return document.getElementById('explorer').dataset.revision;"), "2");
  EXPECT_NE(MustGet(fleet.port, "/map.svg").body().find("(the head), relaxed layout"),
            std::string::npos)
      << "relaxed by default";
  ExpectTheMapZooms(browser);
  ExpectAClickedNodesFacts(browser, *repository, fleet.robot_name);

  // A channel's map: its link shows revision 1, the first push's 8 nodes.
  browser.Click("#explorer nav a[href=\"/?r=1\"]");
  ASSERT_TRUE(browser.WaitFor(
      "const e = document.getElementById('explorer'); return !!e && e.dataset.revision === '1' "
      "&& document.getElementById('map').dataset.ready !== undefined;",
      std::chrono::seconds(30)))
      << fleet.server.Log();
  EXPECT_EQ(browser.Run("return document.querySelectorAll('#map #nodes circle').length;"), 8);
  EXPECT_NE(browser.Run("return document.querySelector('#map svg title').textContent;")
                .get<std::string>()
                .find("revision 1"),
            std::string::npos);

  browser.Navigate(url);
  ASSERT_TRUE(browser.WaitFor(kMapReady, std::chrono::seconds(30)));
  ExpectRevisionTwosChange(browser, *repository);
}

}  // namespace
}  // namespace fleetmap
