#pragma once
// The DDS domain of one test process: a domain no other running test process on this host holds.
// Every test that talks DDS (in process or through a child `regolith` it spawns) takes its domain
// from here, so concurrent tests - `ctest -j`, or two suites on one machine - never share one.
// Namespaces already keep most topics apart, but the global ones (/clock, /tf, /rosout,
// /parameter_events) are not namespaced, and a recording of "every topic" sees a neighbour's.
//
// The claim is an exclusive flock on /tmp/regolith-test-dds-domain-<id>.lock held until the
// process ends (the kernel releases it then, also after a crash). Domains 100..229 (Cyclone's
// default port mapping allows ids up to 232); the search starts at an offset from the pid.
#include <cstdint>
#include <string>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

namespace regolith::testing {

inline std::uint32_t test_domain() {
  static const std::uint32_t domain = [] {
    constexpr std::uint32_t kFirst = 100, kCount = 130;
    const std::uint32_t start = static_cast<std::uint32_t>(getpid()) % kCount;
    for (std::uint32_t i = 0; i < kCount; ++i) {
      const std::uint32_t d = kFirst + (start + i) % kCount;
      const std::string lock = "/tmp/regolith-test-dds-domain-" + std::to_string(d) + ".lock";
      const int fd = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0666);
      if (fd < 0) continue;                               // e.g. another user's lock file
      if (::flock(fd, LOCK_EX | LOCK_NB) == 0) return d;  // fd stays open: the claim lasts the process
      ::close(fd);
    }
    return kFirst + start;  // all 130 held: share one, as the namespaces still separate most topics
  }();
  return domain;
}

}  // namespace regolith::testing
