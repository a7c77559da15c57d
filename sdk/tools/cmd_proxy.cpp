// kata proxy: ZeroMQ's own forwarder between many publishers and many subscribers, so sources
// publish to one endpoint, consumers subscribe at one endpoint, and any number of `kata serve`
// shards sit in between (docs/deploy.md). It is zmq_proxy_steerable over an XSUB socket (the
// publishers connect to --frontend) and an XPUB socket (the subscribers connect to --backend):
// subscriptions travel upstream, messages downstream, topic frames and multi-part messages
// untouched. Nothing of kata's is parsed here; a restarted proxy is rejoined by ZeroMQ's own
// reconnection (the runtime re-sends skeleton definitions when a subscriber joins).
//
// It prints a status line every --status-interval seconds (messages and bytes each way, from
// the proxy's STATISTICS command) and exits cleanly on SIGINT/SIGTERM (TERMINATE on the control
// socket) or after --seconds.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <thread>

#include <zmq.hpp>

#include "data_files.hpp"
#include "command.hpp"
#include "common/error.hpp"
#include "transport/curve.hpp"

namespace {

struct ProxyArgs {
  // This host only by default; other hosts with --key and --clients (or --insecure).
  std::string frontend = "tcp://127.0.0.1:5560";
  std::string backend = "tcp://127.0.0.1:5561";
  std::string key, clients;  // CURVE: the proxy's .secret, the allowed clients' key directory
  bool insecure = false;
  int64_t max_message_bytes = 1 << 20;
  double seconds = 0.0;          // 0: until a signal
  double status_interval = 1.0;  // seconds; 0: quiet
  int hwm = 100000;              // messages queued per peer before ZeroMQ drops (PUB side)
};

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }

void run_proxy(const ProxyArgs& a) {
  kata::transport::CurveOptions curve;
  if (!a.key.empty()) {
    curve.own = kata::transport::read_key_file(a.key);
    if (curve.own.secret_key.empty()) throw kata::Error(kata::ErrorKind::kInvalidArgument, "proxy: --key must be a .secret file");
    if (!a.clients.empty()) curve.allowed_clients = kata::transport::read_key_directory(a.clients);
  } else if (!a.clients.empty()) {
    throw kata::Error(kata::ErrorKind::kInvalidArgument, "proxy: --clients needs --key");
  }
  for (const std::string* e : {&a.frontend, &a.backend})
    if (kata::transport::reachable_beyond_host(*e) && !curve.enabled()) {
      if (!a.insecure)
        throw kata::Error(kata::ErrorKind::kInvalidArgument,
                          "proxy: " + *e + " is reachable from other hosts without keys: give --key and --clients "
                          "(kata keygen; " + kata::cli::doc_file("deploy.md") + "), or --insecure");
      std::fprintf(stderr, "kata proxy: warning: %s bound without keys (--insecure): anyone on the network can "
                           "publish and subscribe\n", e->c_str());
    }
  zmq::context_t context(1);
  // The ZAP handler answers for both sides (one allow-list), before they bind.
  std::unique_ptr<kata::transport::ZapHandler> zap;
  if (curve.enabled()) zap = std::make_unique<kata::transport::ZapHandler>(context.handle(), curve.allowed_clients);
  zmq::socket_t frontend(context, zmq::socket_type::xsub);
  zmq::socket_t backend(context, zmq::socket_type::xpub);
  // Every process gets its own control endpoint.
  const std::string control_endpoint = "inproc://kata-proxy-control";
  zmq::socket_t control(context, zmq::socket_type::pair);
  zmq::socket_t controller(context, zmq::socket_type::pair);
  for (zmq::socket_t* s : {&frontend, &backend}) {
    s->set(zmq::sockopt::rcvhwm, a.hwm);
    s->set(zmq::sockopt::sndhwm, a.hwm);
    s->set(zmq::sockopt::linger, 0);
    s->set(zmq::sockopt::maxmsgsize, a.max_message_bytes);
    s->set(zmq::sockopt::handshake_ivl, 2000);
    kata::transport::apply_curve(s->handle(), curve);
  }
  try {
    frontend.bind(a.frontend);
    backend.bind(a.backend);
  } catch (const zmq::error_t& e) {
    throw kata::Error(kata::ErrorKind::kIo, "proxy: cannot bind " + a.frontend + " / " + a.backend + ": " + e.what());
  }
  control.bind(control_endpoint);
  controller.connect(control_endpoint);

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::thread proxy([&] {
    try {
      zmq::proxy_steerable(frontend, backend, zmq::socket_ref(), control);
    } catch (const zmq::error_t&) {
      // The context is closing: the proxy ends.
    }
  });

  std::printf("kata proxy: publishers -> %s, subscribers <- %s\n", a.frontend.c_str(), a.backend.c_str());
  std::fflush(stdout);
  const auto start = std::chrono::steady_clock::now();
  auto next_status = start;
  while (!g_stop.load()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const auto now = std::chrono::steady_clock::now();
    if (a.seconds > 0.0 && std::chrono::duration<double>(now - start).count() >= a.seconds) break;
    if (a.status_interval > 0.0 && now >= next_status) {
      next_status = now + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                              std::chrono::duration<double>(a.status_interval));
      // STATISTICS answers 8 frames of uint64: frontend msgs in, bytes in, msgs out, bytes out,
      // then the same for the backend.
      controller.send(zmq::str_buffer("STATISTICS"), zmq::send_flags::none);
      uint64_t v[8] = {};
      for (int i = 0; i < 8; ++i) {
        zmq::message_t m;
        if (!controller.recv(m, zmq::recv_flags::none)) break;
        if (m.size() == sizeof(uint64_t)) std::memcpy(&v[i], m.data(), sizeof(uint64_t));
      }
      std::printf("\rkata proxy: frames in %llu (%llu B), out %llu (%llu B); subscriptions %llu   ",
                  static_cast<unsigned long long>(v[0]), static_cast<unsigned long long>(v[1]),
                  static_cast<unsigned long long>(v[6]), static_cast<unsigned long long>(v[7]),
                  static_cast<unsigned long long>(v[4]));
      std::fflush(stdout);
    }
  }
  controller.send(zmq::str_buffer("TERMINATE"), zmq::send_flags::none);
  proxy.join();
  frontend.close();
  backend.close();
  control.close();
  controller.close();
  zap.reset();  // its socket closes before the context terminates
  std::printf("\nkata proxy: stopped\n");
}

void setup(CLI::App& app) {
  auto a = std::make_shared<ProxyArgs>();
  CLI::App* cmd = app.add_subcommand(
      "proxy", "forward frames and results between many publishers and subscribers (ZeroMQ XSUB/XPUB)");
  cmd->add_option("--frontend", a->frontend, "endpoint publishers connect to (XSUB)")->capture_default_str();
  cmd->add_option("--backend", a->backend, "endpoint subscribers connect to (XPUB)")->capture_default_str();
  cmd->add_option("--seconds", a->seconds, "stop after this many seconds (0: on SIGINT/SIGTERM)")->capture_default_str();
  cmd->add_option("--status-interval", a->status_interval, "seconds between status lines (0: none)")->capture_default_str();
  cmd->add_option("--hwm", a->hwm, "high-water mark per peer, messages")->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--key", a->key, "CURVE: the proxy's key pair (kata keygen's .secret)");
  cmd->add_option("--clients", a->clients, "CURVE: directory of allowed publishers' and subscribers' public keys (*.pub)");
  cmd->add_flag("--insecure", a->insecure, "allow binding beyond this host without keys (warned)");
  cmd->add_option("--max-message-bytes", a->max_message_bytes, "larger messages drop their sender (ZMQ_MAXMSGSIZE)")
      ->capture_default_str();
  cmd->callback([a] { run_proxy(*a); });
}

const kata::cli::RegisterCommand reg(setup);

}  // namespace
