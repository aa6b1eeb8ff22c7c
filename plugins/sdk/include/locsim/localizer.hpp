// C++ layer over the localizer ABI: write a class, register it with one macro.
//
//   class MyFilter : public locsim::sdk::Localizer {
//    public:
//     explicit MyFilter(const locsim_init& init);
//     void on_odometry(double t, const locsim_odometry& odometry) override;
//     locsim::sdk::Estimate estimate() const override;
//   };
//   static constexpr locsim_param_decl kParams[] = {
//       {"gain", LOCSIM_PARAM_DOUBLE, 0.5, 0.0, 1.0, nullptr, "how much to trust it [-]"}};
//   LOCSIM_LOCALIZER(MyFilter, "my_filter", "What it does, in one line", kParams)
//
// Exceptions thrown by the class are caught here, on the plugin's side, and returned to the host
// as errors with their message.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstring>
#include <exception>
#include <iterator>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "locsim/localizer.h"

namespace locsim::sdk {

/// The validated parameters of an instance, by name.
class Params {
 public:
  explicit Params(const locsim_init& init) : values_(init.params, init.params + init.param_count) {}
  double number(std::string_view name) const { return find(name).number; }
  long long integer(std::string_view name) const {
    return static_cast<long long>(find(name).number);
  }
  bool flag(std::string_view name) const { return find(name).number != 0.0; }
  std::string string(std::string_view name) const {
    const locsim_param_value& v = find(name);
    return v.string != nullptr ? v.string : "";
  }

 private:
  const locsim_param_value& find(std::string_view name) const {
    for (const locsim_param_value& v : values_) {
      if (name == v.name) return v;
    }
    throw std::invalid_argument("no parameter '" + std::string(name) + "' was declared");
  }
  std::vector<locsim_param_value> values_;
};

struct Estimate {
  locsim_pose2 pose{0.0, 0.0, 0.0};
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
};

class Localizer {
 public:
  virtual ~Localizer() = default;
  /// Dispatches by kind to the on_* handlers; override to see every reading yourself.
  virtual void update(const locsim_reading& reading) {
    switch (reading.kind) {
      case LOCSIM_READING_ODOMETRY:
        on_odometry(reading.t_s, reading.data.odometry);
        break;
      case LOCSIM_READING_IMU:
        on_imu(reading.t_s, reading.data.imu);
        break;
      case LOCSIM_READING_LANDMARKS:
        on_landmarks(reading.t_s, reading.data.landmarks);
        break;
      case LOCSIM_READING_BEACON_RANGES:
        on_beacon_ranges(reading.t_s, reading.data.beacon_ranges);
        break;
      case LOCSIM_READING_LASER:
        on_laser(reading.t_s, reading.data.laser);
        break;
      default:
        break;  // a kind from a newer host: ignore
    }
  }
  virtual void on_odometry(double /*t_s*/, const locsim_odometry&) {}
  virtual void on_imu(double /*t_s*/, const locsim_imu&) {}
  virtual void on_landmarks(double /*t_s*/, const locsim_landmarks&) {}
  virtual void on_beacon_ranges(double /*t_s*/, const locsim_beacon_ranges&) {}
  virtual void on_laser(double /*t_s*/, const locsim_laser_scan&) {}

  virtual Estimate estimate() const = 0;
  /// Optional: the particle cloud (poses and normalised weights; empty when there is none).
  virtual void particles(std::vector<locsim_pose2>& /*poses*/,
                         std::vector<double>& /*weights*/) const {}
  /// Optional: named numbers for metrics.
  virtual std::vector<std::pair<std::string, double>> diagnostics() const { return {}; }
  /// Optional, for SLAM filters: the landmark map as estimated.
  virtual void landmark_map(std::vector<locsim_mapped_landmark>& /*landmarks*/) const {}
};

namespace detail {

inline void copy_error(char* error, size_t size, const char* message) {
  if (error == nullptr || size == 0) return;
  std::strncpy(error, message, size - 1);
  error[size - 1] = '\0';
}

/// Runs `body`, turning any exception into an error return.
template <class Body>
int guarded(char* error, size_t size, Body&& body) {
  try {
    body();
    return 0;
  } catch (const std::exception& e) {
    copy_error(error, size, e.what());
  } catch (...) {
    copy_error(error, size, "unknown exception");
  }
  return 1;
}

/// An instance plus the storage for what it hands back (valid until the next call).
template <class T>
struct Holder {
  explicit Holder(const locsim_init& init) : filter(init) {}
  T filter;
  std::vector<locsim_pose2> poses;
  std::vector<double> weights;
  std::vector<std::pair<std::string, double>> diagnostics;
  std::vector<locsim_mapped_landmark> landmarks;
};

template <class T>
struct Adapter {
  static void* create(const locsim_init* init, char* error, size_t size) {
    Holder<T>* holder = nullptr;
    guarded(error, size, [&] { holder = new Holder<T>(*init); });
    return holder;
  }
  static void destroy(void* instance) { delete static_cast<Holder<T>*>(instance); }
  static int update(void* instance, const locsim_reading* reading, char* error, size_t size) {
    return guarded(error, size,
                   [&] { static_cast<Holder<T>*>(instance)->filter.update(*reading); });
  }
  static int estimate(void* instance, locsim_estimate* out, char* error, size_t size) {
    return guarded(error, size, [&] {
      const Estimate e = static_cast<Holder<T>*>(instance)->filter.estimate();
      out->pose = e.pose;
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) out->covariance[3 * r + c] = e.covariance(r, c);
      }
    });
  }
  static int particles(void* instance, locsim_particles* out, char* error, size_t size) {
    return guarded(error, size, [&] {
      auto* holder = static_cast<Holder<T>*>(instance);
      holder->poses.clear();
      holder->weights.clear();
      holder->filter.particles(holder->poses, holder->weights);
      out->poses = holder->poses.data();
      out->weights =
          holder->weights.size() == holder->poses.size() ? holder->weights.data() : nullptr;
      out->count = holder->poses.size();
    });
  }
  static int diagnostics(void* instance, locsim_diagnostic* out, size_t capacity, size_t* count,
                         char* error, size_t size) {
    return guarded(error, size, [&] {
      auto* holder = static_cast<Holder<T>*>(instance);
      holder->diagnostics = holder->filter.diagnostics();
      *count = std::min(capacity, holder->diagnostics.size());
      for (size_t i = 0; i < *count; ++i) {
        out[i] = {holder->diagnostics[i].first.c_str(), holder->diagnostics[i].second};
      }
    });
  }
};

template <class T>
int landmark_map(void* instance, locsim_landmark_map* out, char* error, size_t size) {
  return guarded(error, size, [&] {
    auto* holder = static_cast<Holder<T>*>(instance);
    holder->landmarks.clear();
    holder->filter.landmark_map(holder->landmarks);
    out->landmarks = holder->landmarks.data();
    out->count = holder->landmarks.size();
  });
}

/// The kinds of reading `T` handles: the on_* handlers it (or a base of it between it and
/// Localizer) overrides. `&T::on_x` names the member of the class that declares it, so its type
/// is Localizer's exactly when T inherits the handler. A class that overrides `update` itself may
/// look at anything: 0, not said.
template <class T>
constexpr uint32_t handled_readings() {
  const auto overrides = [](auto derived, auto base) {
    return !std::is_same_v<decltype(derived), decltype(base)>;
  };
  if (overrides(&T::update, &Localizer::update)) return 0u;
  uint32_t bits = 0u;
  if (overrides(&T::on_odometry, &Localizer::on_odometry))
    bits |= LOCSIM_READING_BIT(LOCSIM_READING_ODOMETRY);
  if (overrides(&T::on_imu, &Localizer::on_imu)) bits |= LOCSIM_READING_BIT(LOCSIM_READING_IMU);
  if (overrides(&T::on_landmarks, &Localizer::on_landmarks))
    bits |= LOCSIM_READING_BIT(LOCSIM_READING_LANDMARKS);
  if (overrides(&T::on_beacon_ranges, &Localizer::on_beacon_ranges))
    bits |= LOCSIM_READING_BIT(LOCSIM_READING_BEACON_RANGES);
  if (overrides(&T::on_laser, &Localizer::on_laser))
    bits |= LOCSIM_READING_BIT(LOCSIM_READING_LASER);
  return bits;
}

template <class T>
constexpr locsim_localizer make_table(const char* name, const char* description,
                                      const locsim_param_decl* params, size_t param_count) {
  return locsim_localizer{LOCSIM_LOCALIZER_ABI_VERSION,
                          static_cast<uint32_t>(sizeof(locsim_localizer)),
                          name,
                          description,
                          params,
                          param_count,
                          &Adapter<T>::create,
                          &Adapter<T>::destroy,
                          nullptr,
                          &Adapter<T>::update,
                          &Adapter<T>::estimate,
                          &Adapter<T>::particles,
                          &Adapter<T>::diagnostics,
                          &landmark_map<T>,
                          handled_readings<T>()};
}

}  // namespace detail
}  // namespace locsim::sdk

/// Registers `Class` (constructible from `const locsim_init&`) as the plugin's localizer.
#define LOCSIM_LOCALIZER(Class, name, description, params)                            \
  extern "C" LOCSIM_EXPORT const locsim_localizer* locsim_localizer_entry(uint32_t) { \
    static const locsim_localizer table = ::locsim::sdk::detail::make_table<Class>(   \
        name, description, std::data(params), std::size(params));                     \
    return &table;                                                                    \
  }

/// The same for a localizer without parameters.
#define LOCSIM_LOCALIZER_NO_PARAMS(Class, name, description)                          \
  extern "C" LOCSIM_EXPORT const locsim_localizer* locsim_localizer_entry(uint32_t) { \
    static const locsim_localizer table =                                             \
        ::locsim::sdk::detail::make_table<Class>(name, description, nullptr, 0);      \
    return &table;                                                                    \
  }
