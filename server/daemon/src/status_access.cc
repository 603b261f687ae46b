#include "status_access.h"

#include <boost/beast/http/field.hpp>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "fleetmap/core/error.h"
#include "fleetmap/daemon/status_http.h"
#include "fleetmap/wire/secret_file.h"

namespace fleetmap {
namespace {

namespace http = boost::beast::http;

// Shorter tokens are guessable over a network; `openssl rand -hex 32` gives 64 characters.
constexpr std::size_t kMinTokenLength = 16;

// The value of `name` among `text`'s `separator`-separated name=value pairs; empty when absent.
std::string_view ValueOf(std::string_view text, char separator, std::string_view name) {
  while (!text.empty()) {
    const std::size_t end = std::min(text.find(separator), text.size());
    std::string_view pair = text.substr(0, end);
    while (!pair.empty() && pair.front() == ' ') pair.remove_prefix(1);
    if (pair.size() > name.size() && pair.substr(0, name.size()) == name &&
        pair[name.size()] == '=') {
      return pair.substr(name.size() + 1);
    }
    text.remove_prefix(std::min(end + 1, text.size()));
  }
  return {};
}

}  // namespace

bool ConstantTimeEquals(std::string_view a, std::string_view b) {
  // Every byte of b is looked at whatever a holds; a's bytes past b's length only through
  // the length difference.
  unsigned char differ = a.size() == b.size() ? 0 : 1;
  for (std::size_t i = 0; i < b.size(); ++i) {
    const unsigned char from_a = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    differ = static_cast<unsigned char>(differ | (from_a ^ static_cast<unsigned char>(b[i])));
  }
  return differ == 0;
}

StatusAccess CheckStatusAccess(const HttpRequest& request, std::string_view token) {
  const auto field = [&request](http::field name) {
    const auto value = request[name];
    return std::string_view(value.data(), value.size());
  };
  // Each way is checked (no early return), so the time does not say which one was tried.
  constexpr std::string_view kBearer = "Bearer ";
  const std::string_view authorization = field(http::field::authorization);
  const bool by_header = authorization.size() > kBearer.size() &&
                         authorization.substr(0, kBearer.size()) == kBearer &&
                         ConstantTimeEquals(authorization.substr(kBearer.size()), token);
  const bool by_cookie =
      ConstantTimeEquals(ValueOf(field(http::field::cookie), ';', kStatusTokenCookie), token);
  const std::string_view target(request.target().data(), request.target().size());
  const std::size_t query = target.find('?');
  const bool by_query = query != std::string_view::npos &&
                        ConstantTimeEquals(ValueOf(target.substr(query + 1), '&', "token"), token);
  if (by_header || by_cookie) return StatusAccess::kByHeaderOrCookie;
  return by_query ? StatusAccess::kByQuery : StatusAccess::kDenied;
}

HttpResponse StatusUnauthorized(const HttpRequest& request) {
  HttpResponse response =
      PlainTextResponse(http::status::unauthorized, request.version(), request.keep_alive(),
                        "this status server needs its token (fleetmapd --http-token-file): send "
                        "\"Authorization: Bearer TOKEN\", or open /?token=TOKEN in a browser");
  response.set(http::field::www_authenticate, "Bearer realm=\"fleetmapd\"");
  return response;
}

std::string StatusTokenCookie(std::string_view token) {
  return std::string(kStatusTokenCookie) + "=" + std::string(token) +
         "; Path=/; HttpOnly; SameSite=Strict";
}

std::string ReadStatusHttpToken(const std::string& path) {
  RequirePrivateSecretFile(path, "--http-token-file");
  std::ifstream in(path);
  std::stringstream content;
  content << in.rdbuf();
  if (!in) {
    throw Error(ErrorCode::kInvalidArgument, "--http-token-file " + path + ": cannot be read");
  }
  std::string token = content.str();
  while (!token.empty() && std::isspace(static_cast<unsigned char>(token.back()))) {
    token.pop_back();
  }
  // Characters a URL's query and a cookie carry as they are.
  const bool plain = token.find_first_not_of(
                         "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                         "0123456789-._~") == std::string::npos;
  if (token.size() < kMinTokenLength || !plain) {
    throw Error(ErrorCode::kInvalidArgument,
                "--http-token-file " + path + ": the token must be at least " +
                    std::to_string(kMinTokenLength) +
                    " characters of A-Z, a-z, 0-9, '-', '.', '_', '~' on one line (e.g. "
                    "`openssl rand -hex 32 > " +
                    path + "`)");
  }
  return token;
}

}  // namespace fleetmap
