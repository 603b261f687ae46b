// A plain HTTP/1.0 GET to fleetmapd's status server on IPv4 loopback, for the cross-process
// tests that read /metrics and the status page.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <string>

namespace fleetmap::testing {

// A response as received: its status code (0 when none came), header block and body.
struct HttpReply {
  int status = 0;
  std::string headers;
  std::string body;
};

// GET `target` from HOST:PORT (IPv4 loopback) over HTTP/1.0 with `extra_headers` (each line
// ending in "\r\n"); the whole response.
inline HttpReply HttpGetReply(const std::string& address, const std::string& target,
                              const std::string& extra_headers = "") {
  const std::size_t colon = address.rfind(':');
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(std::stoi(address.substr(colon + 1))));
  if (inet_pton(AF_INET, address.substr(0, colon).c_str(), &to.sin_addr) != 1) return {};
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return {};
  timeval timeout{5, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  std::string response;
  if (connect(fd, reinterpret_cast<const sockaddr*>(&to), sizeof to) == 0) {
    const std::string request =
        "GET " + target + " HTTP/1.0\r\nHost: test\r\n" + extra_headers + "\r\n";
    if (write(fd, request.data(), request.size()) == static_cast<ssize_t>(request.size())) {
      char buffer[8192];
      for (ssize_t n; (n = read(fd, buffer, sizeof buffer)) > 0;) response.append(buffer, n);
    }
  }
  close(fd);
  HttpReply reply;
  const std::size_t body = response.find("\r\n\r\n");
  if (body == std::string::npos) return reply;
  reply.headers = response.substr(0, body);
  reply.body = response.substr(body + 4);
  // "HTTP/1.1 200 OK"
  const std::size_t space = reply.headers.find(' ');
  if (space != std::string::npos) reply.status = std::atoi(reply.headers.c_str() + space + 1);
  return reply;
}

// GET `target` from HOST:PORT (IPv4 loopback) over HTTP/1.0; the body, "" on any failure.
inline std::string HttpGet(const std::string& address, const std::string& target) {
  return HttpGetReply(address, target).body;
}

}  // namespace fleetmap::testing
