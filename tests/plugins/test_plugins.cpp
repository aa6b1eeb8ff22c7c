// Plugins that misbehave on purpose, one per failure the host must survive or report, plus a
// no-op (host overhead) and a hashing one (every filter sees the same readings). Each is built
// from this file with LOCSIM_TEST_PLUGIN set to its kind.
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstring>
#include <limits>
#include <locsim/localizer.hpp>
#include <stdexcept>
#include <thread>

namespace {

/// Counts readings, hashes their kinds, times and payload sizes.
class Probe : public locsim::sdk::Localizer {
 public:
  explicit Probe(const locsim_init& init) : pose_{init.initial_pose} {}
  void update(const locsim_reading& r) override {
    ++readings_;
    mix(static_cast<std::uint64_t>(r.kind));
    std::uint64_t t;
    std::memcpy(&t, &r.t_s, sizeof t);
    mix(t);
    if (r.kind == LOCSIM_READING_LASER) {
      for (size_t i = 0; i < r.data.laser.count; ++i) {
        std::uint32_t bits;
        std::memcpy(&bits, &r.data.laser.ranges[i], sizeof bits);
        mix(bits);
      }
    }
    if (r.kind == LOCSIM_READING_ODOMETRY)
      mix(static_cast<std::uint64_t>(r.data.odometry.left_ticks));
    on_reading(r);
  }
  virtual void on_reading(const locsim_reading&) {}
  locsim::sdk::Estimate estimate() const override { return {pose_, Eigen::Matrix3d::Identity()}; }
  std::vector<std::pair<std::string, double>> diagnostics() const override {
    return {{"readings", static_cast<double>(readings_)},
            {"hash", static_cast<double>(hash_ >> 12)}};
  }

 protected:
  void mix(std::uint64_t v) {
    hash_ ^= v;
    hash_ *= 0x100000001b3ULL;
  }
  locsim_pose2 pose_;
  long readings_ = 0;
  std::uint64_t hash_ = 0xcbf29ce484222325ULL;
};

#if defined(LOCSIM_TEST_THROWS)
class Plugin final : public Probe {
 public:
  using Probe::Probe;
  void on_reading(const locsim_reading& r) override {
    if (r.t_s >= 1.0) throw std::runtime_error("deliberate failure at one second");
  }
};
#elif defined(LOCSIM_TEST_NAN)
class Plugin final : public Probe {
 public:
  using Probe::Probe;
  void on_reading(const locsim_reading& r) override { t_ = r.t_s; }
  locsim::sdk::Estimate estimate() const override {
    locsim::sdk::Estimate e{pose_, Eigen::Matrix3d::Identity()};
    if (t_ >= 2.0) e.pose.x = std::numeric_limits<double>::quiet_NaN();
    return e;
  }

 private:
  double t_ = 0.0;
};
#elif defined(LOCSIM_TEST_CREATE_FAILS)
class Plugin final : public Probe {
 public:
  explicit Plugin(const locsim_init& init) : Probe(init) {
    throw std::invalid_argument("needs a map with at least 100 landmarks");
  }
};
#elif defined(LOCSIM_TEST_SEGFAULT)
class Plugin final : public Probe {
 public:
  using Probe::Probe;
  void on_reading(const locsim_reading& r) override {
    if (r.t_s >= 1.0) std::raise(SIGSEGV);  // as a wild pointer would
  }
};
#elif defined(LOCSIM_TEST_HANG)
class Plugin final : public Probe {
 public:
  using Probe::Probe;
  void on_reading(const locsim_reading& r) override {
    while (r.t_s >= 1.0) std::this_thread::sleep_for(std::chrono::seconds(1));  // never returns
  }
};
#elif defined(LOCSIM_TEST_NOOP)
/// Does nothing at all: what is measured is the host.
class Plugin final : public locsim::sdk::Localizer {
 public:
  explicit Plugin(const locsim_init&) {}
  void update(const locsim_reading&) override {}
  locsim::sdk::Estimate estimate() const override { return {}; }
};
#else
using Plugin = Probe;
#endif

constexpr locsim_param_decl kParams[] = {
    {"gain", LOCSIM_PARAM_DOUBLE, 0.5, 0.0, 1.0, nullptr, "unused [-]"},
    {"count", LOCSIM_PARAM_INT, 10, 1, 100, nullptr, "unused [-]"},
    {"verbose", LOCSIM_PARAM_BOOL, 0, 0, 1, nullptr, "unused"},
    {"mode", LOCSIM_PARAM_STRING, 0, 0, 0, "fast", "unused"},
};

}  // namespace

#if defined(LOCSIM_TEST_BAD_ABI) || defined(LOCSIM_TEST_BAD_SIZE)
// A table from another SDK: the host must refuse it with both versions / sizes.
extern "C" LOCSIM_EXPORT const locsim_localizer* locsim_localizer_entry(uint32_t) {
  static locsim_localizer table =
      locsim::sdk::detail::make_table<Plugin>(LOCSIM_TEST_NAME, "bad", kParams, 4);
#if defined(LOCSIM_TEST_BAD_ABI)
  table.abi_version = 99;
#else
  table.struct_size = 24;
#endif
  return &table;
}
#elif defined(LOCSIM_TEST_NO_ENTRY)
extern "C" LOCSIM_EXPORT int locsim_something_else() {
  return 42;
}
#else
#if defined(LOCSIM_TEST_UNRESOLVED)
// An exported pointer to a function defined nowhere: its relocation must be resolved at load time.
extern "C" void locsim_function_nobody_defines();
extern "C" {
LOCSIM_EXPORT void (*locsim_unresolved_reference)() = &locsim_function_nobody_defines;
}
#endif
LOCSIM_LOCALIZER(Plugin, LOCSIM_TEST_NAME, "a test plugin", kParams)
#endif
