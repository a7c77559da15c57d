// The live viewer's server: static files (the page, three.js) and a server-sent-events stream of
// the lesson, on localhost, with cpp-httplib (Debian libcpp-httplib-dev).
//
// GET /            the page (viewer/index.html)
// GET /events      text/event-stream: "setup" (skeleton, settings; first on every connection),
//                  then "frame" events with ids 0, 1, 2... (one per student frame, JSON), then
//                  "end" (the summary) when the lesson is over. A client that reconnects sends
//                  Last-Event-ID (EventSource does) and receives only the frames after it; a new
//                  client receives every frame so far (the timeline), then the live ones.
// GET /status      {"lesson": id, "frames": n, "ended": bool} (for the page after an end, scripts)
//
// Threads: publish() from the lesson's thread; httplib's thread pool serves clients. Events are
// kept (the whole lesson: ~1 kB a frame) under one mutex that only this app's threads take.
#pragma once

#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace httplib {
class Server;
}

namespace kata::coach {

// "WHO: cannot listen on HOST:PORT: <the reason> (...; --port 0 picks a free port)": httplib
// reports a failed bind without its cause, so the bind is tried once more on a plain socket for it.
std::string cannot_listen_message(const char* who, const std::string& host, int port);

class ViewerServer {
 public:
  // Serves `static_dir` on host:port (port 0: any free port). Throws kata::Error(kIo) when the
  // port cannot be bound or the directory has no index.html.
  ViewerServer(const std::string& static_dir, const std::string& host, int port);
  ~ViewerServer();
  ViewerServer(const ViewerServer&) = delete;
  ViewerServer& operator=(const ViewerServer&) = delete;

  int port() const { return port_; }
  void set_setup(std::string json);
  void set_lesson_id(std::string id);  // reported by /status
  void publish(std::string json);  // the next frame event
  void end(std::string json);      // the lesson is over
  // Closes every connection and stops listening (also done by the destructor).
  void stop();

 private:

  std::unique_ptr<httplib::Server> server_;
  std::thread thread_;
  int port_ = 0;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::string setup_, end_, lesson_id_;
  std::vector<std::string> frames_;
  bool stopping_ = false;
};

}  // namespace kata::coach
