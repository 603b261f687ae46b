// Who may read the status server (status_http.h): the page and /metrics name every robot, its
// UUID, channel and last error, so with a token set (fleetmapd --http-token-file) a request
// is answered only when it carries that token, and 401 otherwise.
//
// A request carries the token in any of three ways:
//   - "Authorization: Bearer TOKEN" (a Prometheus scraper's `authorization` / curl -H);
//   - "?token=TOKEN" in its target (a person's browser, typed once), answered with a cookie
//     so that the page's picture and its reloads carry it too;
//   - that cookie, "fleetmapd_status_token=TOKEN" (HttpOnly, SameSite=Strict).
// Tokens are compared in constant time (in the token's length), so an answer's timing says
// nothing about how much of a guess was right.
#pragma once

#include <string_view>

#include "status_routes.h"

namespace fleetmap {

inline constexpr std::string_view kStatusTokenCookie = "fleetmapd_status_token";

enum class StatusAccess {
  kDenied,
  kByHeaderOrCookie,
  kByQuery,  // the response should set the cookie (StatusTokenCookie)
};

// How `request` carries `token`. REQUIRES: token not empty.
StatusAccess CheckStatusAccess(const HttpRequest& request, std::string_view token);

// The 401 for a request without the token: it names the three ways, not the token.
HttpResponse StatusUnauthorized(const HttpRequest& request);

// The Set-Cookie value that lets a browser's later requests carry `token`.
std::string StatusTokenCookie(std::string_view token);

// a == b, in a time that depends on b's length only.
bool ConstantTimeEquals(std::string_view a, std::string_view b);

}  // namespace fleetmap
