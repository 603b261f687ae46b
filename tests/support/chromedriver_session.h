// A WebDriver session with real headless Chromium through ChromeDriver (Debian's chromium-driver,
// installed by scripts/setup), both on 127.0.0.1, for the browser tests that act on a page: click
// a button, turn the mouse wheel over an element (WebDriver's input actions, which Chromium
// dispatches as a user's), run a script to read what the page shows. Bounded: every call has a
// deadline, and the destructor ends the session and ChromeDriver (and so Chromium).
//
// Failures are test failures (ADD_FAILURE or a thrown std::runtime_error that fails the test),
// never skips: CI installs ChromeDriver.
#pragma once

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/core/tcp_stream.hpp>
#include <boost/beast/http.hpp>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>

#include "fleetmap/core/child_process.h"
#include "scratch_dir.h"

namespace fleetmap::testing {

inline std::string ChromeDriverPath() {
  const char* configured = std::getenv("FLEETMAP_CHROMEDRIVER");
  return configured != nullptr ? configured : "/usr/bin/chromedriver";
}

class ChromeDriverSession {
 public:
  // Starts ChromeDriver on a free loopback port and a session of headless Chromium with a fresh
  // profile under `scratch`, its window `width` x `height` pixels.
  explicit ChromeDriverSession(const ScratchDir& scratch, int width = 1200, int height = 900) {
    if (!std::filesystem::exists(ChromeDriverPath())) {
      throw std::runtime_error("ChromeDriver not found at " + ChromeDriverPath() +
                               ": the browser tests need it (scripts/setup installs "
                               "chromium-driver; or set FLEETMAP_CHROMEDRIVER)");
    }
    port_ = FreeLoopbackPort();
    ChildProcessOptions options;
    options.stderr_file = scratch / "chromedriver.log";
    driver_ = std::make_unique<ChildProcess>(
        std::vector<std::string>{ChromeDriverPath(), "--port=" + std::to_string(port_),
                                 "--allowed-ips=127.0.0.1"},
        options);
    if (!driver_->ReadLineContaining("started successfully", std::chrono::seconds(20))) {
      throw std::runtime_error("ChromeDriver did not start within 20 s");
    }
    const char* chromium = std::getenv("FLEETMAP_CHROMIUM");
    nlohmann::json chrome_options = {
        {"binary", chromium != nullptr ? chromium : "/usr/bin/chromium"},
        {"args",
         {"--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
          "--no-first-run", "--window-size=" + std::to_string(width) + "," + std::to_string(height),
          "--user-data-dir=" + (scratch / "webdriver-profile").string()}}};
    const nlohmann::json created =
        Call(boost::beast::http::verb::post, "/session",
             {{"capabilities", {{"alwaysMatch", {{"goog:chromeOptions", chrome_options}}}}}});
    session_ = created.at("sessionId").get<std::string>();
  }

  ~ChromeDriverSession() {
    try {
      if (!session_.empty()) Call(boost::beast::http::verb::delete_, "/session/" + session_, {});
    } catch (const std::exception&) {
      // ChildProcess's destructor kills ChromeDriver either way.
    }
  }
  ChromeDriverSession(const ChromeDriverSession&) = delete;
  ChromeDriverSession& operator=(const ChromeDriverSession&) = delete;

  void Navigate(const std::string& url) { Session("/url", {{"url", url}}); }

  // `script`'s return value (a function body: `return ...;`), with `args` as its arguments.
  nlohmann::json Run(const std::string& script, nlohmann::json args = nlohmann::json::array()) {
    return Session("/execute/sync", {{"script", script}, {"args", std::move(args)}});
  }

  // Polls `script` (which returns true or false) every 100 ms until it returns true or
  // `timeout` passes; whether it did.
  bool WaitFor(const std::string& script, std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      if (Run(script) == true) return true;
      if (std::chrono::steady_clock::now() > deadline) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }

  // The WebDriver reference of the first element `css` selects (throws when there is none).
  nlohmann::json Element(const std::string& css) {
    return Session("/element", {{"using", "css selector"}, {"value", css}});
  }

  // A user's click on the first element `css` selects.
  void Click(const std::string& css) {
    const nlohmann::json element = Element(css);
    Session("/element/" + element.begin().value().get<std::string>() + "/click",
            nlohmann::json::object());
  }

  // A user's turn of the mouse wheel over the centre of the first element `css` selects:
  // `delta_y` pixels (negative: away from the user, which zooms in).
  void Wheel(const std::string& css, int delta_y) {
    const nlohmann::json element = Element(css);
    Session("/actions", {{"actions",
                          {{{"type", "wheel"},
                            {"id", "wheel"},
                            {"actions",
                             {{{"type", "scroll"},
                               {"x", 0},
                               {"y", 0},
                               {"deltaX", 0},
                               {"deltaY", delta_y},
                               {"origin", element}}}}}}}});
  }

 private:
  static std::uint16_t FreeLoopbackPort() {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t length = sizeof address;
    if (fd < 0 || bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 ||
        getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) != 0) {
      if (fd >= 0) close(fd);
      throw std::runtime_error("no free loopback port for ChromeDriver");
    }
    close(fd);
    return ntohs(address.sin_port);
  }

  nlohmann::json Session(const std::string& path, const nlohmann::json& body) {
    return Call(boost::beast::http::verb::post, "/session/" + session_ + path, body);
  }

  // One WebDriver command: its "value", or a std::runtime_error with WebDriver's message.
  nlohmann::json Call(boost::beast::http::verb verb, const std::string& target,
                      const nlohmann::json& body) {
    namespace http = boost::beast::http;
    boost::asio::io_context io;
    boost::beast::tcp_stream stream(io);
    stream.expires_after(std::chrono::seconds(60));
    stream.connect(
        boost::asio::ip::tcp::endpoint(boost::asio::ip::make_address("127.0.0.1"), port_));
    http::request<http::string_body> request{verb, target, 11};
    request.set(http::field::host, "127.0.0.1");
    request.set(http::field::content_type, "application/json");
    if (verb != http::verb::delete_) request.body() = body.dump();
    request.prepare_payload();
    http::write(stream, request);
    boost::beast::flat_buffer buffer;
    http::response<http::string_body> response;
    http::read(stream, buffer, response);
    const nlohmann::json reply = nlohmann::json::parse(response.body(), nullptr, false);
    if (reply.is_discarded() || !reply.contains("value")) {
      throw std::runtime_error("WebDriver " + target + ": not JSON: " + response.body());
    }
    if (response.result() != http::status::ok) {
      throw std::runtime_error("WebDriver " + target + ": " + reply["value"].dump());
    }
    return reply["value"];
  }

  std::uint16_t port_ = 0;
  std::unique_ptr<ChildProcess> driver_;
  std::string session_;
};

}  // namespace fleetmap::testing
