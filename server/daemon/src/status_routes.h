// The routes of the status HTTP server (status_http.h): one request in, one response out,
// no I/O — so the connection code knows nothing about pages and metrics.
#pragma once

#include <boost/beast/http/message.hpp>
#include <boost/beast/http/string_body.hpp>
#include <functional>

#include "fleetmap/daemon/fleet_status.h"

namespace fleetmap {

using HttpRequest = boost::beast::http::request<boost::beast::http::string_body>;
using HttpResponse = boost::beast::http::response<boost::beast::http::string_body>;

// GET / → status page, GET /metrics → Prometheus text, GET /healthz → "ok", GET /map.svg →
// the head's picture as FleetStatus holds it (503 until the first is drawn); other paths 404,
// other methods 405 (with Allow: GET). `status_source` is called for all but /healthz;
// when it throws, 500 with its message. The response keeps the request's HTTP version and
// keep-alive choice and has its Content-Length set.
HttpResponse RouteStatusRequest(const HttpRequest& request,
                                const std::function<FleetStatus()>& status_source);

// A complete plain-text response (used for errors found before routing, like 413).
HttpResponse PlainTextResponse(boost::beast::http::status status, unsigned version, bool keep_alive,
                               const std::string& text);

}  // namespace fleetmap
