#include "status_routes.h"

#include <boost/beast/http/field.hpp>
#include <boost/beast/http/verb.hpp>
#include <exception>
#include <optional>
#include <string>
#include <string_view>

#include "fleet_metrics.h"
#include "fleetmap/core/clock.h"
#include "status_page.h"

namespace fleetmap {
namespace {

namespace http = boost::beast::http;

constexpr const char* kServerName = "fleetmapd-status";

HttpResponse Response(http::status status, unsigned version, bool keep_alive,
                      std::string_view content_type, std::string body) {
  HttpResponse response{status, version};
  response.set(http::field::server, kServerName);
  response.set(http::field::content_type,
               boost::beast::string_view(content_type.data(), content_type.size()));
  // Every answer is a live snapshot: a cache would show a stale fleet.
  response.set(http::field::cache_control, "no-store");
  response.keep_alive(keep_alive);
  response.body() = std::move(body);
  response.prepare_payload();
  return response;
}

// The value of `name` in a query string ("r=7&x=1"): nullopt when absent, -1 when it is not
// a plain decimal number.
std::optional<std::int64_t> QueryNumber(std::string_view query, std::string_view name) {
  while (!query.empty()) {
    const std::size_t amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    query = amp == std::string_view::npos ? std::string_view() : query.substr(amp + 1);
    const std::size_t eq = pair.find('=');
    if (pair.substr(0, eq) != name) continue;
    const std::string_view value =
        eq == std::string_view::npos ? std::string_view() : pair.substr(eq + 1);
    std::int64_t number = 0;
    if (value.empty() || value.size() > 18) return -1;
    for (const char c : value) {
      if (c < '0' || c > '9') return -1;
      number = number * 10 + (c - '0');
    }
    return number;
  }
  return std::nullopt;
}

// A picture and its nodes' facts: GET /map.svg, /map.json, /change.svg, /change.json.
HttpResponse PictureResponse(const FleetStatus& status, PictureKind kind, bool json,
                             std::optional<std::int64_t> asked, unsigned version, bool keep_alive) {
  const std::string content_type = json ? "application/json" : "image/svg+xml";
  const bool head_map = kind == PictureKind::kMap &&
                        (!asked || *asked == status.picture_revision) && status.head_picture_svg;
  if (head_map) {
    // Drawn once per head revision off this thread (status_pictures.h); here only copied out.
    return Response(http::status::ok, version, keep_alive, content_type,
                    json ? (status.head_picture_nodes ? *status.head_picture_nodes : "[]")
                         : *status.head_picture_svg);
  }
  const std::int64_t revision = asked.value_or(status.head_revision);
  if (revision < 1 || revision > status.head_revision) {
    return PlainTextResponse(http::status::not_found, version, keep_alive,
                             "no revision " + std::to_string(revision) + ": the history is 1.." +
                                 std::to_string(status.head_revision));
  }
  std::shared_ptr<const ServedPicture> picture;
  if (status.find_picture) picture = status.find_picture(kind, revision);
  if (!picture) {
    HttpResponse response =
        PlainTextResponse(http::status::service_unavailable, version, keep_alive,
                          "the picture of revision " + std::to_string(revision) +
                              " is being drawn; ask again in a moment");
    response.set(http::field::retry_after, "1");
    return response;
  }
  return Response(http::status::ok, version, keep_alive, content_type,
                  json ? picture->nodes_json : picture->svg);
}

FleetStatus Snapshot(const std::function<FleetStatus()>& status_source) {
  FleetStatus status = status_source();
  if (status.now_ns == 0) {
    status.now_ns = WallClockNs();
  }
  return status;
}

}  // namespace

HttpResponse PlainTextResponse(http::status status, unsigned version, bool keep_alive,
                               const std::string& text) {
  return Response(status, version, keep_alive, "text/plain; charset=utf-8", text + "\n");
}

HttpResponse RouteStatusRequest(const HttpRequest& request,
                                const std::function<FleetStatus()>& status_source) {
  const unsigned version = request.version();
  const bool keep_alive = request.keep_alive();
  std::string_view path(request.target().data(), request.target().size());
  std::string_view query;
  if (const auto mark = path.find('?'); mark != std::string_view::npos) {
    query = path.substr(mark + 1);
    path = path.substr(0, mark);
  }
  const bool picture =
      path == "/map.svg" || path == "/map.json" || path == "/change.svg" || path == "/change.json";
  const bool known = path == "/" || path == "/metrics" || path == "/healthz" || picture;
  if (request.method() != http::verb::get) {
    HttpResponse response =
        PlainTextResponse(http::status::method_not_allowed, version, keep_alive,
                          "method " + std::string(request.method_string()) + " not allowed");
    response.set(http::field::allow, "GET");
    return response;
  }
  if (!known) {
    return PlainTextResponse(
        http::status::not_found, version, keep_alive,
        "no page at " + std::string(path) +
            " (try /, /metrics, /healthz, /map.svg, /map.json, /change.svg, /change.json)");
  }
  if (path == "/healthz") {
    return Response(http::status::ok, version, keep_alive, "text/plain; charset=utf-8", "ok");
  }
  const std::optional<std::int64_t> r = QueryNumber(query, "r");
  const std::optional<std::int64_t> change = QueryNumber(query, "change");
  if ((r && *r < 0) || (change && *change < 0)) {
    return PlainTextResponse(http::status::bad_request, version, keep_alive,
                             "a revision (r=, change=) is a decimal number");
  }
  try {
    const FleetStatus status = Snapshot(status_source);
    if (picture) {
      const PictureKind kind =
          path.starts_with("/change") ? PictureKind::kChange : PictureKind::kMap;
      return PictureResponse(status, kind, path.ends_with(".json"), r, version, keep_alive);
    }
    if (path == "/metrics") {
      return Response(http::status::ok, version, keep_alive,
                      "text/plain; version=0.0.4; charset=utf-8", FleetMetricsText(status));
    }
    PageView view;
    if (change || r) {
      view.kind = change ? PictureKind::kChange : PictureKind::kMap;
      view.revision = change ? *change : *r;
      if (view.revision < 1 || view.revision > status.head_revision) {
        return PlainTextResponse(http::status::not_found, version, keep_alive,
                                 "no revision " + std::to_string(view.revision) +
                                     ": the history is 1.." + std::to_string(status.head_revision));
      }
    }
    return Response(http::status::ok, version, keep_alive, "text/html; charset=utf-8",
                    FleetStatusPage(status, view));
  } catch (const std::exception& e) {
    return PlainTextResponse(http::status::internal_server_error, version, keep_alive,
                             std::string("status unavailable: ") + e.what());
  }
}

}  // namespace fleetmap
