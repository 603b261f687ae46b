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

// GET / → status page (?r=R: its explorer shows the map of revision R; ?change=R: what R
// changed), GET /metrics → Prometheus text, GET /healthz → "ok", GET /map.svg and /map.json →
// a revision's picture and its nodes' facts (fleet_status.h ServedPicture; ?r=R, default the
// head's picture), GET /change.svg and /change.json → what revision R changed (?r=R, default
// the head). A picture not drawn yet is 503 with Retry-After: 1 (it is being drawn); a
// revision outside 1..head is 404, a malformed one 400. Other paths 404, other methods 405
// (with Allow: GET). `status_source` is called for all but /healthz; when it throws, 500 with
// its message. The response keeps the request's HTTP version and keep-alive choice and has its
// Content-Length set.
HttpResponse RouteStatusRequest(const HttpRequest& request,
                                const std::function<FleetStatus()>& status_source);

// A complete plain-text response (used for errors found before routing, like 413).
HttpResponse PlainTextResponse(boost::beast::http::status status, unsigned version, bool keep_alive,
                               const std::string& text);

}  // namespace fleetmap
