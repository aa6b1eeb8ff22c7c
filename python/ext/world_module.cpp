// _locsim_world: the simulation stepped from Python (`locsim.World`, python/locsim/world.py). A
// producer like `locsim run`'s: the same world files, the same per-seed world variation and the
// same Simulation, so a world stepped here is the run's world step for step (a test compares the
// state hashes); readings come out as Python objects with numpy arrays, robots without a driver
// take velocity commands. No localizers, files or video: `locsim.run` does those.
#include <dlfcn.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <type_traits>
#include <variant>

#include "render/loader.hpp"
#include "sim/common/errors.hpp"
#include "sim/producers/simulation.hpp"
#include "sim/run/runner.hpp"
#include "sim/sensors/models.hpp"
#include "sim/world/variation.hpp"

namespace py = pybind11;

namespace locsim {
namespace {

py::array_t<double> pose_array(const Pose2& p) {
  py::array_t<double> out(3);
  auto v = out.mutable_unchecked<1>();
  v(0) = p.x, v(1) = p.y, v(2) = p.theta;
  return out;
}

/// Detections as a structured array (id, range_m, bearing_rad, target, truth_id) and their colours.
py::dict detections(const std::vector<Detection>& list) {
  struct Row {
    std::int32_t id;
    double range_m, bearing_rad;
    std::int32_t target, truth_id;
  };
  py::list names, formats, offsets;
  for (const auto& [name, format, offset] : {std::tuple{"id", "<i4", offsetof(Row, id)},
                                             {"range_m", "<f8", offsetof(Row, range_m)},
                                             {"bearing_rad", "<f8", offsetof(Row, bearing_rad)},
                                             {"target", "<i4", offsetof(Row, target)},
                                             {"truth_id", "<i4", offsetof(Row, truth_id)}}) {
    names.append(name), formats.append(format), offsets.append(offset);
  }
  py::dict spec;
  spec["names"] = names, spec["formats"] = formats, spec["offsets"] = offsets,
  spec["itemsize"] = sizeof(Row);
  py::array out(py::dtype::from_args(spec), {list.size()}, {sizeof(Row)});
  auto* rows = static_cast<Row*>(out.mutable_data());
  py::list colors;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const Detection& d = list[i];
    rows[i] = {d.id, d.range_m, d.bearing_rad, static_cast<std::int32_t>(d.target), d.truth_id};
    colors.append(d.color);
  }
  py::dict fields;
  fields["detections"] = out, fields["colors"] = colors;
  return fields;
}

/// One reading as a dict: t_s, robot, sensor (its YAML key), then the sensor's fields; a laser
/// scan with what a plugin's on_laser gets beside its ranges (`world`: the robots' laser defs).
py::dict to_python(const Reading& r, const WorldDef& world) {
  py::dict out;
  out["t_s"] = r.t_s, out["robot"] = r.robot, out["sensor"] = std::string(sensor_name(r.kind));
  std::visit(
      [&](const auto& data) {
        using T = std::decay_t<decltype(data)>;
        if constexpr (std::is_same_v<T, OdometryReading>) {
          out["left_ticks"] = data.left_ticks, out["right_ticks"] = data.right_ticks;
          out["pose"] = pose_array(data.odometry);
          out["v_mps"] = data.v_mps, out["omega_radps"] = data.omega_radps;
          out["fields"] = data.fields;
        } else if constexpr (std::is_same_v<T, ImuReading>) {
          out["yaw_rate_radps"] = data.yaw_rate_radps;
          out["accel_x_mps2"] = data.accel_mps2.x(), out["accel_y_mps2"] = data.accel_mps2.y();
        } else if constexpr (std::is_same_v<T, PtzReading>) {
          out["pan_rad"] = data.pan_rad, out["tilt_rad"] = data.tilt_rad, out["zoom"] = data.zoom;
          for (const auto& [key, value] : detections(data.detections)) out[key] = value;
        } else if constexpr (std::is_same_v<T, OmniReading> ||
                             std::is_same_v<T, RangeBearingReading>) {
          for (const auto& [key, value] : detections(data.detections)) out[key] = value;
        } else if constexpr (std::is_same_v<T, UltrasonicReading>) {
          py::array_t<std::int32_t> receiver(data.ranges.size()), beacon(data.ranges.size());
          py::array_t<double> range(data.ranges.size());
          py::list status;
          for (std::size_t i = 0; i < data.ranges.size(); ++i) {
            receiver.mutable_at(i) = data.ranges[i].receiver;
            beacon.mutable_at(i) = data.ranges[i].beacon_id;
            range.mutable_at(i) = data.ranges[i].range_m;
            status.append(range_status_name(data.ranges[i].truth_status));
          }
          out["receiver"] = receiver, out["beacon_id"] = beacon, out["range_m"] = range;
          out["truth_status"] = status;
        } else if constexpr (std::is_same_v<T, LaserScan>) {
          out["ranges_m"] = py::array_t<float>(data.ranges_m.size(), data.ranges_m.data());
          const LaserDef& laser = *world.robots.at(static_cast<std::size_t>(r.robot)).sensors.laser;
          py::array_t<double> angles(data.ranges_m.size());
          for (std::size_t b = 0; b < data.ranges_m.size(); ++b) {
            angles.mutable_at(b) =
                laser_beam_angle(static_cast<int>(b), laser.beams, laser.fov_rad);
          }
          out["angles_rad"] = angles;  // in the sensor frame, as on_laser's
          out["range_min_m"] = laser.min_range_m, out["range_max_m"] = laser.max_range_m;
          out["mount"] = pose_array(laser.common.mount);  // the sensor's pose on the robot
        }
      },
      r.data);
  return out;
}

/// Where the render module is, from this module's folder: the build's (build/python/..), then the
/// install's (share/locsim/python to LIBDIR/locsim). The executable here is python3, so the
/// loader's default (the locsim binary's folder) does not apply.
std::vector<std::filesystem::path> render_module_folders() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&render_module_folders), &info) == 0 ||
      info.dli_fname == nullptr)
    return {};
  const std::filesystem::path here = std::filesystem::path(info.dli_fname).parent_path();
  return {here.parent_path(), here / LOCSIM_RENDER_FROM_PYTHON};
}

/// PTZ cameras in mode: rendered draw their images with the render module, loaded on first use as
/// `locsim run` loads it ($LOCSIM_RENDER_MODULE, else beside this module's build or install).
LandmarkImagerFactory imagers() {
  return [](const WorldDef& world, const PtzCameraDef& camera) {
    static const std::shared_ptr<render::RenderModule> module =
        render::RenderModule::load(render_module_folders());
    return module->make_imager(world, camera, "osmesa");
  };
}

/// A world loaded as `locsim run` loads it, simulated step by step.
class World {
 public:
  World(const std::string& world_file, std::uint64_t seed,
        const std::optional<std::string>& scenario, std::optional<double> duration_s,
        bool variation)
      : inputs_(load_run_inputs(
            world_file, scenario ? std::optional<std::filesystem::path>(*scenario) : std::nullopt,
            duration_s)) {
    if (!variation) inputs_.world.variation.enabled = false;
    vary_world(inputs_.world, inputs_.scenario, seed);
    sim_.emplace(inputs_.world, inputs_.scenario, seed, imagers());
  }

  /// Advances up to `steps` physics steps (fewer at the scenario's end); returns those taken.
  std::int64_t step(std::int64_t steps) {
    std::int64_t taken = 0;
    for (; taken < steps && !sim_->done(); ++taken) sim_->step();
    return taken;
  }
  /// Steps until the time reaches `t_s` (or the scenario ends).
  std::int64_t run_until(double t_s) {
    const auto target = static_cast<std::int64_t>(std::ceil(t_s / sim_->dt_s() - 1e-9));
    return step(std::max<std::int64_t>(0, target - sim_->step_index()));
  }

  py::array_t<double> truth() const {
    py::array_t<double> out({static_cast<py::ssize_t>(sim_->robot_count()), py::ssize_t{3}});
    auto v = out.mutable_unchecked<2>();
    for (std::size_t i = 0; i < sim_->robot_count(); ++i) {
      const Pose2 p = sim_->robot(i).pose();
      const auto r = static_cast<py::ssize_t>(i);
      v(r, 0) = p.x, v(r, 1) = p.y, v(r, 2) = p.theta;
    }
    return out;
  }

  py::list readings() {
    py::list out;
    for (const Reading& r : sim_->take_readings()) out.append(to_python(r, sim_->world_def()));
    return out;
  }

  py::list events() {
    py::list out;
    for (const SimEvent& e : sim_->take_events()) {
      py::dict d;
      d["t_s"] = e.t_s, d["step"] = e.step, d["kind"] = e.kind, d["robot"] = e.robot,
      d["details"] = e.details;
      out.append(d);
    }
    return out;
  }

  void command(const py::object& robot, double v_mps, double omega_radps) {
    sim_->robot(robot_index(robot)).command(v_mps, omega_radps);
  }

  std::vector<std::string> robots() const {
    std::vector<std::string> names;
    for (const RobotDef& r : inputs_.world.robots) names.push_back(r.name);
    return names;
  }

  const Simulation& sim() const { return *sim_; }
  const WorldDef& def() const { return inputs_.world; }

 private:
  std::size_t robot_index(const py::object& robot) const {
    if (py::isinstance<py::str>(robot)) {
      const std::string name = robot.cast<std::string>();
      for (std::size_t i = 0; i < inputs_.world.robots.size(); ++i) {
        if (inputs_.world.robots[i].name == name) return i;
      }
      throw py::key_error("no robot '" + name + "' in the world");
    }
    const auto i = robot.cast<std::int64_t>();
    if (i < 0 || static_cast<std::size_t>(i) >= sim_->robot_count())
      throw py::index_error("robot " + std::to_string(i) + " of " +
                            std::to_string(sim_->robot_count()));
    return static_cast<std::size_t>(i);
  }

  RunInputs inputs_;
  std::optional<Simulation> sim_;
};

}  // namespace
}  // namespace locsim

PYBIND11_MODULE(_locsim_world, m) {
  using locsim::World;
  m.doc() = "locsim's simulation stepped from Python; use it as locsim.World (docs/python.md)";
  // Bad input is the user's to fix: a ValueError naming the file, line and key, as the CLI says it.
  py::register_exception<locsim::InputError>(m, "InputError", PyExc_ValueError);
  py::register_exception<locsim::RenderError>(m, "RenderError", PyExc_RuntimeError);
  py::class_<World>(m, "World")
      .def(py::init<const std::string&, std::uint64_t, const std::optional<std::string>&,
                    std::optional<double>, bool>(),
           py::arg("world"), py::arg("seed") = 1, py::arg("scenario") = py::none(),
           py::arg("duration") = py::none(), py::arg("variation") = true)
      .def("step", &World::step, py::arg("steps") = 1)
      .def("run_until", &World::run_until, py::arg("t_s"))
      .def("truth", &World::truth)
      .def("readings", &World::readings)
      .def("events", &World::events)
      .def("command", &World::command, py::arg("robot"), py::arg("v_mps"), py::arg("omega_radps"))
      .def_property_readonly("robots", &World::robots)
      .def_property_readonly("time_s", [](const World& w) { return w.sim().time_s(); })
      .def_property_readonly("dt_s", [](const World& w) { return w.sim().dt_s(); })
      .def_property_readonly("step_index", [](const World& w) { return w.sim().step_index(); })
      .def_property_readonly("end_step", [](const World& w) { return w.sim().end_step(); })
      .def_property_readonly("done", [](const World& w) { return w.sim().done(); })
      .def_property_readonly("seed", [](const World& w) { return w.sim().seed(); })
      .def_property_readonly("name", [](const World& w) { return w.def().name; })
      .def("state_hash", [](const World& w) { return w.sim().state_hash(); });
}
