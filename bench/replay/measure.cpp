// kata-replay: CPU, memory and percentiles (replay.hpp).
#include "replay.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

namespace kata::replay {

int64_t now_ns() { return kata::pipeline::now_ns(); }

double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// CPU time of every thread of this process (ns on a CPU, /proc/self/task/TID/schedstat), by the
// thread's name (kata-worker0.., kata-io, ZMQbg/IO/0, ...; the main thread is "kata"), summed
// over threads of one name. Threads that ended since are missing: take it while they run.
// With each: its voluntary context switches (the times it went to sleep: a wake-up each).
std::map<std::string, ThreadUse> thread_cpu_ns() {
  std::map<std::string, ThreadUse> by_name;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/proc/self/task", ec)) {
    std::ifstream comm(entry.path() / "comm"), sched(entry.path() / "schedstat"), status(entry.path() / "status");
    std::string name, line;
    double ns = 0.0;
    if (!std::getline(comm, name) || !(sched >> ns)) continue;
    by_name[name].ns += ns;
    while (std::getline(status, line))
      if (line.rfind("voluntary_ctxt_switches:", 0) == 0)
        by_name[name].sleeps += std::stod(line.substr(24));
      else if (line.rfind("nonvoluntary_ctxt_switches:", 0) == 0)
        by_name[name].preempted += std::stod(line.substr(27));
  }
  return by_name;
}

// The q-quantile (us) of a sorted sample (ns): the element at rank round(q (n - 1)).
double quantile_of_sorted(const std::vector<int64_t>& sorted, double q) {
  if (sorted.empty()) return 0.0;
  const size_t k = std::min(sorted.size() - 1, static_cast<size_t>(q * static_cast<double>(sorted.size() - 1) + 0.5));
  return static_cast<double>(sorted[k]) / 1000.0;
}

// Percentiles of samples that stay in arrival order: a sorted copy is ranked, never the samples
// themselves. (Ranking them in place, as this file once did with nth_element before the soak's
// windows were cut from the same vector by receive time, moved small values to the front and
// large ones to the back: an apparent latency growth with the age of the run; docs/runtime.md.)
double percentile(const std::vector<int64_t>& v, double q) {
  std::vector<int64_t> sorted(v);
  std::sort(sorted.begin(), sorted.end());
  return quantile_of_sorted(sorted, q);
}

json summary(const std::vector<int64_t>& ns) {
  std::vector<int64_t> sorted(ns);
  std::sort(sorted.begin(), sorted.end());
  json j;
  j["p50_us"] = quantile_of_sorted(sorted, 0.50);
  j["p99_us"] = quantile_of_sorted(sorted, 0.99);
  j["p999_us"] = quantile_of_sorted(sorted, 0.999);
  j["max_us"] = sorted.empty() ? 0.0 : static_cast<double>(sorted.back()) / 1000.0;
  return j;
}

double thread_cpu_us() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return 1e6 * static_cast<double>(t.tv_sec) + 1e-3 * static_cast<double>(t.tv_nsec);
}

// This process's resident set (MiB), from /proc/self/statm.
double resident_mib() {
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (!f) return 0.0;
  unsigned long long size = 0, resident = 0;
  const int n = std::fscanf(f, "%llu %llu", &size, &resident);
  std::fclose(f);
  if (n != 2) return 0.0;
  return static_cast<double>(resident) * static_cast<double>(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

// utime + stime of a process (s), from /proc/PID/stat (clock ticks); 0 when it is gone.
double process_cpu_seconds(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
  const std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const size_t close = text.rfind(')');  // the command name may hold spaces: fields follow its ')'
  if (close == std::string::npos) return 0.0;
  std::istringstream rest(text.substr(close + 2));
  std::string skip;
  for (int field = 3; field <= 13; ++field) rest >> skip;  // state .. cmajflt
  double utime = 0.0, stime = 0.0;
  rest >> utime >> stime;
  return (utime + stime) / static_cast<double>(sysconf(_SC_CLK_TCK));
}

}  // namespace kata::replay
