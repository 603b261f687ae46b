#include "status_routes.h"

#include <boost/beast/http/field.hpp>
#include <boost/beast/http/verb.hpp>
#include <exception>
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
  if (const auto query = path.find('?'); query != std::string_view::npos) {
    path = path.substr(0, query);
  }
  const bool known = path == "/" || path == "/metrics" || path == "/healthz" || path == "/map.svg";
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
        "no page at " + std::string(path) + " (try /, /metrics, /healthz, /map.svg)");
  }
  if (path == "/healthz") {
    return Response(http::status::ok, version, keep_alive, "text/plain; charset=utf-8", "ok");
  }
  try {
    const FleetStatus status = Snapshot(status_source);
    if (path == "/map.svg") {
      // Drawn once per head revision off this thread (head_picture.h); here only copied out.
      if (!status.head_picture_svg) {
        return PlainTextResponse(http::status::service_unavailable, version, keep_alive,
                                 "the picture of revision " + std::to_string(status.head_revision) +
                                     " is being drawn; ask again in a moment");
      }
      return Response(http::status::ok, version, keep_alive, "image/svg+xml",
                      *status.head_picture_svg);
    }
    if (path == "/metrics") {
      return Response(http::status::ok, version, keep_alive,
                      "text/plain; version=0.0.4; charset=utf-8", FleetMetricsText(status));
    }
    return Response(http::status::ok, version, keep_alive, "text/html; charset=utf-8",
                    FleetStatusPage(status));
  } catch (const std::exception& e) {
    return PlainTextResponse(http::status::internal_server_error, version, keep_alive,
                             std::string("status unavailable: ") + e.what());
  }
}

}  // namespace fleetmap
