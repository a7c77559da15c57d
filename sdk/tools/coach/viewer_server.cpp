#include "coach/viewer_server.hpp"

#include <netdb.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include <httplib.h>

#include "failure.hpp"


namespace kata::coach {

using cli::fail;

std::string cannot_listen_message(const char* who, const std::string& host, int port) {
  std::string reason = "the reason is unknown (the port was free when tried again)";
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_PASSIVE;
  addrinfo* found = nullptr;
  if (const int gai = getaddrinfo(host.c_str(), std::to_string(port).c_str(), &hints, &found); gai != 0) {
    reason = gai_strerror(gai);
  } else {
    const int fd = ::socket(found->ai_family, found->ai_socktype, found->ai_protocol);
    if (fd < 0) {
      reason = std::strerror(errno);
    } else {
      const int yes = 1;  // as httplib binds: a port in TIME_WAIT is not the reason
      ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
      if (::bind(fd, found->ai_addr, found->ai_addrlen) != 0) reason = std::strerror(errno);
      ::close(fd);
    }
    freeaddrinfo(found);
  }
  return std::string(who) + ": cannot listen on " + host + ":" + std::to_string(port) + ": " + reason +
         " (another kata coach or another program on that port? --port 0 picks a free port)";
}

ViewerServer::ViewerServer(const std::string& static_dir, const std::string& host, int port)
    : server_(std::make_unique<httplib::Server>()) {
  if (!std::ifstream(static_dir + "/index.html"))
    fail(static_dir + "/index.html: the viewer page is missing (build the kata_viewer target, "
                                             "or give --viewer-dir)");
  if (!server_->set_mount_point("/", static_dir))
    fail(static_dir + ": cannot serve this directory");
  server_->set_file_extension_and_mimetype_mapping("mjs", "text/javascript");
  server_->Get("/status", [this](const httplib::Request&, httplib::Response& res) {
    std::lock_guard<std::mutex> lock(mutex_);
    res.set_content("{\"lesson\":\"" + lesson_id_ + "\",\"frames\":" + std::to_string(frames_.size()) + ",\"ended\":" + (end_.empty() ? "false" : "true") +
                        "}",
                    "application/json");
  });
  server_->Get("/events", [this](const httplib::Request& req, httplib::Response& res) {
    size_t first = 0;
    // Resume after the last frame the client has: EventSource's own reconnection sends
    // Last-Event-ID, the page's fresh connections send ?last=.
    if (req.has_header("Last-Event-ID")) first = std::strtoull(req.get_header_value("Last-Event-ID").c_str(), nullptr, 10) + 1;
    else if (req.has_param("last")) first = std::strtoull(req.get_param_value("last").c_str(), nullptr, 10) + 1;
    res.set_header("Cache-Control", "no-cache");
    res.set_chunked_content_provider("text/event-stream", [this, next = first, greeted = false](
                                                              size_t, httplib::DataSink& sink) mutable {
      std::string out;
      if (!greeted) {
        std::lock_guard<std::mutex> lock(mutex_);
        out = "retry: 1000\nevent: setup\ndata: " + setup_ + "\n\n";
        greeted = true;
      }
      bool ended = false;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        if (out.empty())
          changed_.wait_for(lock, std::chrono::milliseconds(250),
                            [&] { return stopping_ || frames_.size() > next || !end_.empty(); });
        if (stopping_) return false;
        for (; next < frames_.size() && out.size() < (1u << 20); ++next)
          out += "id: " + std::to_string(next) + "\nevent: frame\ndata: " + frames_[next] + "\n\n";
        if (next == frames_.size() && !end_.empty()) {
          out += "event: end\ndata: " + end_ + "\n\n";
          ended = true;
        }
      }
      if (out.empty()) out = ": keep-alive\n\n";  // also detects a client that went away
      if (!sink.write(out.data(), out.size())) return false;
      if (ended) sink.done();
      return true;
    });
  });
  port_ = port == 0 ? server_->bind_to_any_port(host) : (server_->bind_to_port(host, port) ? port : -1);
  if (port_ <= 0) fail(cannot_listen_message("viewer", host, port));
  thread_ = std::thread([this] { server_->listen_after_bind(); });
}

ViewerServer::~ViewerServer() { stop(); }

void ViewerServer::set_setup(std::string json) {
  std::lock_guard<std::mutex> lock(mutex_);
  setup_ = std::move(json);
}

void ViewerServer::set_lesson_id(std::string id) {
  std::lock_guard<std::mutex> lock(mutex_);
  lesson_id_ = std::move(id);
}

void ViewerServer::publish(std::string json) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    frames_.push_back(std::move(json));
  }
  changed_.notify_all();
}

void ViewerServer::end(std::string json) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    end_ = std::move(json);
  }
  changed_.notify_all();
}

void ViewerServer::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  if (server_) server_->stop();
  if (thread_.joinable()) thread_.join();
}

}  // namespace kata::coach
