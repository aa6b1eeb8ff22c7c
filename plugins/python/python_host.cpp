// locsim_python: runs localizers written in Python (docs/python.md). A loader plugin: for each
// script the host names (`--localizer python:my_filter.py`) locsim_localizer_load returns a table
// whose name, description, parameters and readings are the script's, read from its text by
// python/locsim/_describe.py in a process of its own, so nothing of the user's runs in the host
// process that later forks the filters' workers. create() starts CPython (once per process, never
// finalised: numpy cannot be started twice), imports the script and makes its Localizer; every
// call after that goes to the script's methods, readings as read-only numpy views of the host's
// memory. A Python exception becomes the call's error, naming the script's file and line.
#include <dlfcn.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cfloat>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

// pybind11 before anything else of Python's: it includes Python.h as Python requires.
#include <pybind11/embed.h>
#include <pybind11/numpy.h>
// numpy's own C API, for its allocator hook only (the rest goes through pybind11).
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#include "locsim/localizer.h"

namespace py = pybind11;
namespace fs = std::filesystem;

extern char** environ;

namespace {

// ---------------------------------------------------------------------------------------------
// Where the locsim Python package is: an install's share/locsim/python (this library is in
// lib/locsim/plugins), else the source tree's python/ folder this library was built from.
fs::path package_dir() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&package_dir), &info) != 0 && info.dli_fname != nullptr) {
    const fs::path installed = fs::path(info.dli_fname).parent_path() / LOCSIM_PYTHON_FROM_PLUGINS;
    std::error_code error;
    if (fs::exists(installed / "locsim/__init__.py", error)) return installed.lexically_normal();
  }
  return LOCSIM_PYTHON_SOURCE_DIR;
}

void write_error(char* error, std::size_t size, const std::string& message) {
  if (error == nullptr || size == 0) return;
  const std::size_t n = std::min(size - 1, message.size());
  std::memcpy(error, message.data(), n);
  error[n] = '\0';
}

// ---------------------------------------------------------------------------------------------
// A script's declarations, read without running it. Lives as long as the library, which is never
// unloaded (-z nodelete): the host holds pointers into the table until it exits.
struct Script {
  std::string path, directory, class_name;
  std::deque<std::string> strings;  // stable storage for the table's C strings
  std::vector<locsim_param_decl> params;
  locsim_localizer table{};
  // Imported once per process (two labels of one script share the module, not the instance).
  py::object* module = nullptr;
  std::string import_error;
  bool imported = false;
  const char* keep(std::string text) { return strings.emplace_back(std::move(text)).c_str(); }
};

constexpr std::size_t kMaxScripts = 64;
std::vector<std::unique_ptr<Script>>& scripts() {
  static auto* all = new std::vector<std::unique_ptr<Script>>();  // never destroyed, as the library
  return *all;
}

/// Runs `python3 -I -S _describe.py FILE`: (exit status, stdout, stderr).
std::tuple<int, std::string, std::string> run_describe(const std::string& file) {
  const std::string python = LOCSIM_PYTHON_EXECUTABLE;
  const std::string describe = (package_dir() / "locsim/_describe.py").string();
  int out[2], err[2];
  if (pipe(out) != 0) return {-1, "", std::strerror(errno)};
  if (pipe(err) != 0) {
    close(out[0]), close(out[1]);
    return {-1, "", std::strerror(errno)};
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out[1], 1);
  posix_spawn_file_actions_adddup2(&actions, err[1], 2);
  posix_spawn_file_actions_addclose(&actions, out[0]);
  posix_spawn_file_actions_addclose(&actions, err[0]);
  const char* argv[] = {python.c_str(), "-I", "-S", "-B", describe.c_str(), file.c_str(), nullptr};
  pid_t pid = 0;
  const int spawned =
      posix_spawn(&pid, python.c_str(), &actions, nullptr, const_cast<char* const*>(argv), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(out[1]), close(err[1]);
  std::string texts[2];
  // The answer is a few hundred bytes: reading one pipe then the other cannot fill either.
  for (int k = 0; k < 2; ++k) {
    const int fd = k == 0 ? out[0] : err[0];
    char buffer[4096];
    ssize_t n = 0;
    while ((n = read(fd, buffer, sizeof buffer)) > 0 || (n < 0 && errno == EINTR)) {
      if (n > 0) texts[k].append(buffer, static_cast<std::size_t>(n));
    }
    close(fd);
  }
  if (spawned != 0) return {-1, "", python + ": " + std::strerror(spawned)};
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, texts[0], texts[1]};
}

std::vector<std::string> split(const std::string& line, char separator) {
  std::vector<std::string> fields;
  std::string field;
  std::stringstream in(line);
  while (std::getline(in, field, separator)) fields.push_back(field);
  if (!line.empty() && line.back() == separator) fields.emplace_back();
  return fields;
}

// ---------------------------------------------------------------------------------------------
// numpy's array buffers, each on a 64-byte boundary of its own and 128 bytes or more from any
// other. Why: numpy picks its SIMD loop or its scalar loop for a call (they round transcendental
// functions differently) by how far apart the input and output buffers are and how they are
// aligned; with the C library's heap that depends on everything else the process allocated (the
// log writer, being in a worker or in the host), so a filter's results would change with --log.
// With this allocator they depend on the script alone. The header keeps the size for realloc.
constexpr std::size_t kArrayAlignment = 64;

void* aligned_malloc(void* /*context*/, std::size_t size) {
  const std::size_t padded =
      kArrayAlignment + (size + kArrayAlignment - 1) / kArrayAlignment * kArrayAlignment;
  auto* raw = static_cast<unsigned char*>(std::aligned_alloc(kArrayAlignment, padded));
  if (raw == nullptr) return nullptr;
  std::memcpy(raw, &size, sizeof size);
  return raw + kArrayAlignment;
}
void* aligned_calloc(void* context, std::size_t count, std::size_t item_size) {
  if (item_size != 0 && count > SIZE_MAX / item_size) return nullptr;
  void* p = aligned_malloc(context, count * item_size);
  if (p != nullptr) std::memset(p, 0, count * item_size);
  return p;
}
void aligned_free(void* /*context*/, void* p, std::size_t /*size*/) {
  if (p != nullptr) std::free(static_cast<unsigned char*>(p) - kArrayAlignment);
}
void* aligned_realloc(void* context, void* p, std::size_t size) {
  if (p == nullptr) return aligned_malloc(context, size);
  std::size_t old_size = 0;
  std::memcpy(&old_size, static_cast<unsigned char*>(p) - kArrayAlignment, sizeof old_size);
  void* moved = aligned_malloc(context, size);
  if (moved == nullptr) return nullptr;  // numpy keeps the old buffer, as realloc's contract
  std::memcpy(moved, p, std::min(old_size, size));
  aligned_free(context, p, old_size);
  return moved;
}

PyDataMem_Handler g_aligned_handler = {
    "locsim_aligned_64",
    1,
    {nullptr, aligned_malloc, aligned_calloc, aligned_realloc, aligned_free}};
PyObject* g_aligned_handler_capsule = nullptr;  // lives as the process

/// numpy's handler is a context variable: a thread (or a fresh thread state) starts with the
/// default, so every call makes sure its own context has ours (a pointer compare when it does).
void use_aligned_arrays() {
  PyObject* current = PyDataMem_GetHandler();
  if (current != g_aligned_handler_capsule) {
    PyObject* previous = PyDataMem_SetHandler(g_aligned_handler_capsule);
    if (previous == nullptr) throw py::error_already_set();
    Py_DECREF(previous);
  }
  Py_XDECREF(current);
}

// ---------------------------------------------------------------------------------------------
// The interpreter: started on the first create of the process.
struct Interpreter {
  py::object* locsim = nullptr;      // the locsim.plugin module
  py::object* init_class = nullptr;  // locsim.plugin.Init
  py::object* view_base = nullptr;   // a read-only empty array: views on it are read-only
  py::object* traceback = nullptr;   // the traceback module
  py::dtype* detection_dtype = nullptr;
  py::dtype* beacon_range_dtype = nullptr;
};
Interpreter* g_python = nullptr;

void start_interpreter() {
  if (g_python != nullptr) return;
  // numpy's extension modules do not link libpython: they find its symbols in the global
  // namespace, where the host's RTLD_LOCAL load of this plugin did not put them.
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&Py_Initialize), &info) != 0 && info.dli_fname != nullptr)
    dlopen(info.dli_fname, RTLD_NOW | RTLD_NOLOAD | RTLD_GLOBAL);
  // One thread per filter process, as the C++ filters: the BLAS numpy uses must not start its own
  // (a user's setting wins).
  for (const char* name : {"OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"})
    setenv(name, "1", 0);
  if (Py_IsInitialized() == 0) {
    PyConfig config;
    PyConfig_InitPythonConfig(&config);
    config.parse_argv = 0;
    config.install_signal_handlers = 0;  // Ctrl-C and the watchdog's signals stay the host's
    config.use_hash_seed = 1;            // set and dict-of-str orders the same in every run
    config.hash_seed = 0;
    config.buffered_stdio = 0;  // print() reaches the labelled output before a worker _exits
    // The interpreter this plugin was built against, whatever python3 is first on the PATH (a
    // venv's or pyenv's, without numpy): CPython finds its prefix, and so its packages, from the
    // program's path, and searches the PATH for a bare name. numpy's C API is compiled in, so the
    // numpy it imports must be the one beside that interpreter anyway.
    const PyStatus named =
        PyConfig_SetBytesString(&config, &config.program_name, LOCSIM_PYTHON_EXECUTABLE);
    if (PyStatus_Exception(named)) {
      PyConfig_Clear(&config);
      throw std::runtime_error(named.err_msg != nullptr ? named.err_msg : "PyConfig");
    }
    py::initialize_interpreter(&config, 0, nullptr, false);
  } else {
    PyGILState_Ensure();  // inside a Python process: take the GIL as the code below expects
  }
  auto* python = new Interpreter();  // never freed: the interpreter is never finalised
  if (_import_array() < 0) throw py::error_already_set();  // numpy's C API table
  g_aligned_handler_capsule = PyCapsule_New(&g_aligned_handler, "mem_handler", nullptr);
  if (g_aligned_handler_capsule == nullptr) throw py::error_already_set();
  use_aligned_arrays();  // before the first array below
  py::module_::import("sys").attr("path").attr("insert")(0, package_dir().string());
  python->locsim = new py::object(py::module_::import("locsim.plugin"));
  python->init_class = new py::object(python->locsim->attr("Init"));
  python->traceback = new py::object(py::module_::import("traceback"));
  py::module_::import("_locsim_readings");  // registers the reading types handlers are given
  py::array_t<std::uint8_t> base(0);
  base.attr("setflags")(py::arg("write") = false);
  python->view_base = new py::object(std::move(base));
  const auto dtype = [](std::vector<std::pair<const char*, std::pair<const char*, std::size_t>>> f,
                        std::size_t itemsize) {
    py::list names, formats, offsets;
    for (const auto& [name, format_offset] : f) {
      names.append(name), formats.append(format_offset.first), offsets.append(format_offset.second);
    }
    py::dict spec;
    spec["names"] = names, spec["formats"] = formats, spec["offsets"] = offsets;
    spec["itemsize"] = itemsize;
    return new py::dtype(py::dtype::from_args(spec));
  };
  python->detection_dtype =
      dtype({{"id", {"<i4", offsetof(locsim_detection, id)}},
             {"range_m", {"<f8", offsetof(locsim_detection, range_m)}},
             {"bearing_rad", {"<f8", offsetof(locsim_detection, bearing_rad)}},
             {"target", {"<i4", offsetof(locsim_detection, target)}}},
            sizeof(locsim_detection));
  python->beacon_range_dtype =
      dtype({{"receiver", {"<i4", offsetof(locsim_beacon_range, receiver)}},
             {"beacon_id", {"<i4", offsetof(locsim_beacon_range, beacon_id)}},
             {"range_m", {"<f8", offsetof(locsim_beacon_range, range_m)}},
             {"receiver_x", {"<f8", offsetof(locsim_beacon_range, receiver_x)}},
             {"receiver_y", {"<f8", offsetof(locsim_beacon_range, receiver_y)}},
             {"receiver_height_m", {"<f8", offsetof(locsim_beacon_range, receiver_height_m)}}},
            sizeof(locsim_beacon_range));
  g_python = python;
  PyEval_SaveThread();  // every call takes the GIL (py::gil_scoped_acquire)
}

/// A read-only view of `count` items at `data` (valid during the call only).
template <typename T>
py::array view(const T* data, std::size_t count) {
  return py::array(py::dtype::of<T>(), {count}, {sizeof(T)}, data, *g_python->view_base);
}
py::array view(const py::dtype& dtype, const void* data, std::size_t count, std::size_t stride) {
  return py::array(dtype, {count}, {stride}, data, *g_python->view_base);
}

/// "ValueError: message (my_filter.py:42 in on_landmarks)": where in the script it was raised
/// (the innermost frame in its file; else the innermost frame). The whole traceback goes to
/// stderr, the run's labelled output or the sweep run's log.txt.
std::string describe_error(py::error_already_set& e, const Script& script) {
  std::string type = "Exception", message, place;
  try {
    if (e.type()) type = py::str(e.type().attr("__name__"));
    message = py::str(e.value());
    std::string file, function;
    long line = 0;
    for (py::object tb = py::reinterpret_borrow<py::object>(e.trace()); !tb.is_none();
         tb = tb.attr("tb_next")) {
      const py::object code = tb.attr("tb_frame").attr("f_code");
      const std::string name = py::str(code.attr("co_filename"));
      if (file.empty() || name == script.path || file != script.path) {
        file = name, function = py::str(code.attr("co_name"));
        line = tb.attr("tb_lineno").cast<long>();
      }
    }
    if (py::isinstance(e.value(), py::module_::import("builtins").attr("SyntaxError"))) {
      file = py::str(e.value().attr("filename")), function = "<module>";
      line = e.value().attr("lineno").is_none() ? 0 : e.value().attr("lineno").cast<long>();
    }
    if (!file.empty()) {
      place = " (" + fs::path(file).filename().string() + ":" + std::to_string(line) + " in " +
              function + ")";
    }
    g_python->traceback->attr("print_exception")(e.type(), e.value(), e.trace());
  } catch (const std::exception&) {
    PyErr_Clear();  // describing the error failed: say what is known
  }
  return type + ": " + message + place;
}

// ---------------------------------------------------------------------------------------------
// Reading objects, in an embedded module. Small readings are copied (a few numbers); arrays are
// views.
struct Odometry {
  locsim_odometry data;
};
struct Imu {
  locsim_imu data;
};
struct Landmarks {
  int camera = 0;
  double pan_rad = 0.0;
  py::object detections;
  std::vector<std::string> colors;
};
struct Scan {
  py::object ranges, angles;
  locsim_pose2 mount{};
  double range_min = 0.0, range_max = 0.0;
};

PYBIND11_EMBEDDED_MODULE(_locsim_readings, m) {
  py::class_<Odometry>(m, "Odometry")
      .def_property_readonly("left_ticks", [](const Odometry& o) { return o.data.left_ticks; })
      .def_property_readonly("right_ticks", [](const Odometry& o) { return o.data.right_ticks; })
      .def_property_readonly("meters_per_tick",
                             [](const Odometry& o) { return o.data.meters_per_tick; })
      .def_property_readonly("pose",
                             [](const Odometry& o) {
                               const auto& p = o.data.odom_pose;
                               return py::make_tuple(p.x, p.y, p.theta);
                             })
      .def_property_readonly("fields", [](const Odometry& o) { return o.data.fields; })
      .def_property_readonly("v_mps", [](const Odometry& o) { return o.data.v_mps; })
      .def_property_readonly("omega_radps", [](const Odometry& o) { return o.data.omega_radps; });
  py::class_<Imu>(m, "Imu")
      .def_property_readonly("yaw_rate_radps", [](const Imu& i) { return i.data.yaw_rate_radps; })
      .def_property_readonly("accel_x_mps2", [](const Imu& i) { return i.data.accel_x_mps2; })
      .def_property_readonly("accel_y_mps2", [](const Imu& i) { return i.data.accel_y_mps2; })
      .def_property_readonly("mount_theta", [](const Imu& i) { return i.data.mount_theta; });
  py::class_<Landmarks>(m, "Landmarks")
      .def_readonly("camera", &Landmarks::camera)
      .def_readonly("pan_rad", &Landmarks::pan_rad)
      .def_property_readonly("detections", [](const Landmarks& l) { return l.detections; })
      .def_property_readonly("colors",
                             [](const Landmarks& l) {
                               py::list colors;
                               for (const std::string& c : l.colors) colors.append(c);
                               return colors;
                             })
      .def("__len__", [](const Landmarks& l) { return l.colors.size(); });
  py::class_<Scan>(m, "Scan")
      .def_property_readonly("ranges", [](const Scan& s) { return s.ranges; })
      .def_property_readonly("angles", [](const Scan& s) { return s.angles; })
      .def_property_readonly(
          "mount",
          [](const Scan& s) { return py::make_tuple(s.mount.x, s.mount.y, s.mount.theta); })
      .def_readonly("range_min", &Scan::range_min)
      .def_readonly("range_max", &Scan::range_max);
}

// ---------------------------------------------------------------------------------------------
struct Instance {
  Script* script = nullptr;
  std::string failed;  // the import or the constructor raised: every call says so
  py::object filter, on_odometry, on_imu, on_landmarks, on_beacon_ranges, on_laser, estimate,
      particles, diagnostics, landmark_map;
  long estimate_line = 0;
  // What the last calls returned, alive until the next (the ABI's rule).
  py::array_t<double> particle_poses, particle_weights;
  std::vector<std::string> diagnostic_names;
  std::vector<locsim_mapped_landmark> mapped;
  // The laser's angles: the host's pointer is stable, so one array serves every scan.
  const float* angles_data = nullptr;
  py::object angles;
};

std::string fail_message(const Instance& instance, const std::string& what) {
  return fs::path(instance.script->path).filename().string() + ": " + what;
}

py::object method(const py::object& filter, const char* name) {
  if (!py::hasattr(filter, name)) return py::none();
  return filter.attr(name);
}

py::object make_init(const locsim_init& init) {
  py::dict params;
  for (std::size_t i = 0; i < init.param_count; ++i) {
    const locsim_param_value& v = init.params[i];
    switch (v.type) {
      case LOCSIM_PARAM_INT:
        params[v.name] = static_cast<long long>(std::llround(v.number));
        break;
      case LOCSIM_PARAM_BOOL:
        params[v.name] = v.number != 0.0;
        break;
      case LOCSIM_PARAM_STRING:
        params[v.name] = std::string(v.string != nullptr ? v.string : "");
        break;
      default:
        params[v.name] = v.number;
    }
  }
  const locsim_map& map = *init.map;
  py::array_t<double> landmarks({map.landmark_count, std::size_t{2}});
  py::array_t<long long> landmark_ids(map.landmark_count);
  py::array_t<double> radii(map.landmark_count);
  py::list colors;
  for (std::size_t i = 0; i < map.landmark_count; ++i) {
    const locsim_landmark& l = map.landmarks[i];
    landmarks.mutable_at(i, 0) = l.x, landmarks.mutable_at(i, 1) = l.y;
    landmark_ids.mutable_at(i) = l.id, radii.mutable_at(i) = l.radius_m;
    colors.append(l.color != nullptr ? l.color : "");
  }
  py::array_t<double> beacons({map.beacon_count, std::size_t{3}});
  py::array_t<long long> beacon_ids(map.beacon_count);
  for (std::size_t i = 0; i < map.beacon_count; ++i) {
    const locsim_beacon& b = map.beacons[i];
    beacons.mutable_at(i, 0) = b.x, beacons.mutable_at(i, 1) = b.y,
                          beacons.mutable_at(i, 2) = b.height_m;
    beacon_ids.mutable_at(i) = b.id;
  }
  const locsim_occupancy_grid& g = map.grid;
  const auto rows = static_cast<std::size_t>(std::max(0, g.height));
  const auto cols = static_cast<std::size_t>(std::max(0, g.width));
  py::array_t<std::uint8_t> grid({rows, cols});
  if (rows * cols > 0 && g.cells != nullptr)
    std::memcpy(grid.mutable_data(), g.cells,
                rows * cols);  // the host's grid is valid during create only
  py::array_t<double> pose(3), covariance({std::size_t{3}, std::size_t{3}});
  pose.mutable_at(0) = init.initial_pose.x, pose.mutable_at(1) = init.initial_pose.y,
  pose.mutable_at(2) = init.initial_pose.theta;
  std::memcpy(covariance.mutable_data(), init.initial_covariance, sizeof init.initial_covariance);
  const py::object rng = py::module_::import("numpy").attr("random").attr("default_rng")(init.seed);
  return (*g_python->init_class)(
      py::arg("params") = params, py::arg("seed") = init.seed, py::arg("rng") = rng,
      py::arg("initial_pose_known") = init.initial_pose_known != 0, py::arg("initial_pose") = pose,
      py::arg("initial_covariance") = covariance, py::arg("landmarks") = landmarks,
      py::arg("landmark_ids") = landmark_ids, py::arg("landmark_colors") = colors,
      py::arg("landmark_radii") = radii, py::arg("beacons") = beacons,
      py::arg("beacon_ids") = beacon_ids, py::arg("grid") = grid,
      py::arg("grid_origin") = py::make_tuple(g.origin_x, g.origin_y),
      py::arg("grid_resolution_m") = g.resolution_m,
      py::arg("wheel_base_m") = init.robot->wheel_base_m,
      py::arg("wheel_radius_m") = init.robot->wheel_radius_m,
      py::arg("footprint_radius_m") = init.robot->footprint_radius_m);
}

void* create_instance(Script& script, const locsim_init* init, char* error, std::size_t size) {
  try {
    start_interpreter();
  } catch (const std::exception& e) {
    write_error(error, size,
                std::string("Python (") + LOCSIM_PYTHON_EXECUTABLE + ", the interpreter locsim " +
                    "was built with) could not start: " + e.what() +
                    " (docs/python.md, \"Which Python\")");
    return nullptr;
  }
  py::gil_scoped_acquire gil;
  use_aligned_arrays();
  auto instance = std::make_unique<Instance>();
  instance->script = &script;
  // The script's own failures (an import, its constructor) fail this filter alone, at its first
  // call, as a C++ filter's exception in a call would: the host's create error would end the run.
  try {
    if (!script.imported) {
      script.imported = true;
      try {
        py::module_::import("sys").attr("path").attr("insert")(0, script.directory);
        const py::module_ util = py::module_::import("importlib.util");
        const py::object spec = util.attr("spec_from_file_location")(
            std::string("locsim_localizer_") + script.table.name, script.path);
        py::object module = util.attr("module_from_spec")(spec);
        py::module_::import("sys").attr("modules")[spec.attr("name")] = module;
        spec.attr("loader").attr("exec_module")(module);
        script.module = new py::object(std::move(module));  // lives as the process
      } catch (py::error_already_set& e) {
        script.import_error = "importing it raised " + describe_error(e, script);
      }
    }
    if (!script.import_error.empty()) {
      instance->failed = script.import_error;
    } else {
      const py::object cls = script.module->attr(script.class_name.c_str());
      instance->filter = cls(make_init(*init));
      const py::object& f = instance->filter;
      instance->on_odometry = method(f, "on_odometry");
      instance->on_imu = method(f, "on_imu");
      instance->on_landmarks = method(f, "on_landmarks");
      instance->on_beacon_ranges = method(f, "on_beacon_ranges");
      instance->on_laser = method(f, "on_laser");
      instance->estimate = method(f, "estimate");
      instance->particles = method(f, "particles");
      instance->diagnostics = method(f, "diagnostics");
      instance->landmark_map = method(f, "landmark_map");
      instance->estimate_line =
          instance->estimate.attr("__func__").attr("__code__").attr("co_firstlineno").cast<long>();
    }
  } catch (py::error_already_set& e) {
    instance->failed = "creating " + script.class_name + " raised " + describe_error(e, script);
  } catch (const std::exception& e) {
    instance->failed = std::string("creating it failed: ") + e.what();
  }
  return instance.release();
}

void destroy(void* p) {
  if (p == nullptr) return;
  py::gil_scoped_acquire gil;
  delete static_cast<Instance*>(p);
}

/// Runs `body` with the GIL; a Python exception becomes the call's error.
template <typename Body>
int guarded(Instance& instance, char* error, std::size_t size, Body&& body) {
  if (!instance.failed.empty()) {
    write_error(error, size, fail_message(instance, instance.failed));
    return 1;
  }
  py::gil_scoped_acquire gil;
  try {
    use_aligned_arrays();
    return body();
  } catch (py::error_already_set& e) {
    write_error(error, size, describe_error(e, *instance.script));
  } catch (const std::exception& e) {
    write_error(error, size, fail_message(instance, e.what()));
  }
  return 1;
}

/// The filter's handler of a kind of reading; null when it has none.
const py::object* handler(const Instance& instance, int kind) {
  const py::object* h = nullptr;
  switch (kind) {
    case LOCSIM_READING_ODOMETRY:
      h = &instance.on_odometry;
      break;
    case LOCSIM_READING_IMU:
      h = &instance.on_imu;
      break;
    case LOCSIM_READING_LANDMARKS:
      h = &instance.on_landmarks;
      break;
    case LOCSIM_READING_BEACON_RANGES:
      h = &instance.on_beacon_ranges;
      break;
    case LOCSIM_READING_LASER:
      h = &instance.on_laser;
      break;
    default:
      break;
  }
  return h != nullptr && *h && !h->is_none() ? h : nullptr;
}

int update(void* p, const locsim_reading* reading, char* error, std::size_t size) {
  auto& instance = *static_cast<Instance*>(p);
  // A kind the filter has no handler for costs no GIL.
  if (instance.failed.empty() && handler(instance, reading->kind) == nullptr) return 0;
  return guarded(instance, error, size, [&] {
    const py::object& h = *handler(instance, reading->kind);
    const double t = reading->t_s;
    switch (reading->kind) {
      case LOCSIM_READING_ODOMETRY:
        h(t, Odometry{reading->data.odometry});
        break;
      case LOCSIM_READING_IMU:
        h(t, Imu{reading->data.imu});
        break;
      case LOCSIM_READING_LANDMARKS: {
        const locsim_landmarks& l = reading->data.landmarks;
        Landmarks out;
        out.camera = l.camera, out.pan_rad = l.pan_rad;
        out.detections =
            view(*g_python->detection_dtype, l.detections, l.count, sizeof(locsim_detection));
        out.colors.reserve(l.count);
        for (std::size_t i = 0; i < l.count; ++i)
          out.colors.emplace_back(l.detections[i].color != nullptr ? l.detections[i].color : "");
        h(t, std::move(out));
        break;
      }
      case LOCSIM_READING_BEACON_RANGES: {
        const locsim_beacon_ranges& r = reading->data.beacon_ranges;
        h(t, view(*g_python->beacon_range_dtype, r.ranges, r.count, sizeof(locsim_beacon_range)));
        break;
      }
      case LOCSIM_READING_LASER: {
        const locsim_laser_scan& s = reading->data.laser;
        if (s.angles != instance.angles_data || !instance.angles) {
          instance.angles_data = s.angles;
          instance.angles = view(s.angles, s.count);
        }
        Scan scan;
        scan.ranges = view(s.ranges, s.count);
        scan.angles = instance.angles;
        scan.mount = s.mount, scan.range_min = s.range_min, scan.range_max = s.range_max;
        h(t, std::move(scan));
        break;
      }
      default:
        break;
    }
    return 0;
  });
}

/// `what` as a C-contiguous float64 array of `count` numbers (a copy only when it is not one).
py::array_t<double> numbers(const py::handle& what) {
  return py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(what);
}

int estimate(void* p, locsim_estimate* out, char* error, std::size_t size) {
  auto& instance = *static_cast<Instance*>(p);
  return guarded(instance, error, size, [&] {
    const std::string where = " (" + fs::path(instance.script->path).filename().string() + ":" +
                              std::to_string(instance.estimate_line) + " in estimate)";
    const py::object result = instance.estimate();
    if (!py::isinstance<py::tuple>(result) && !py::isinstance<py::list>(result))
      throw std::runtime_error("estimate() must return (pose, covariance)" + where);
    const py::sequence pair = result;
    if (pair.size() != 2)
      throw std::runtime_error("estimate() must return (pose, covariance)" + where);
    const py::array_t<double> pose = numbers(pair[0]), covariance = numbers(pair[1]);
    if (!pose || pose.size() != 3)
      throw std::runtime_error("estimate(): the pose must be 3 numbers (x, y, theta)" + where);
    if (!covariance || covariance.size() != 9)
      throw std::runtime_error("estimate(): the covariance must be 3 x 3" + where);
    const double* x = pose.data();
    const double* c = covariance.data();
    out->pose = {x[0], x[1], x[2]};
    std::memcpy(out->covariance, c, sizeof out->covariance);
    for (int i = 0; i < 3; ++i)
      if (!std::isfinite(x[i]))
        throw std::runtime_error("estimate() returned a pose that is not finite" + where);
    for (int i = 0; i < 9; ++i)
      if (!std::isfinite(c[i]))
        throw std::runtime_error("estimate() returned a covariance that is not finite" + where);
    return 0;
  });
}

int particles(void* p, locsim_particles* out, char* error, std::size_t size) {
  auto& instance = *static_cast<Instance*>(p);
  *out = {nullptr, nullptr, 0};
  if (instance.failed.empty() && instance.particles.is_none()) return 0;
  return guarded(instance, error, size, [&] {
    const py::object result = instance.particles();
    py::object poses = result, weights = py::none();
    if (py::isinstance<py::tuple>(result) && py::len(result) == 2) {
      poses = result[py::int_(0)], weights = result[py::int_(1)];
    }
    instance.particle_poses = numbers(poses);
    if (!instance.particle_poses || instance.particle_poses.ndim() != 2 ||
        instance.particle_poses.shape(1) != 3)
      throw std::runtime_error("particles() must return poses of shape (N, 3)");
    const auto n = static_cast<std::size_t>(instance.particle_poses.shape(0));
    instance.particle_weights = py::array_t<double>();
    if (!weights.is_none()) {
      instance.particle_weights = numbers(weights);
      if (!instance.particle_weights ||
          static_cast<std::size_t>(instance.particle_weights.size()) != n)
        throw std::runtime_error("particles(): weights must be N numbers, one per pose");
    }
    static_assert(sizeof(locsim_pose2) == 3 * sizeof(double));
    out->poses = reinterpret_cast<const locsim_pose2*>(instance.particle_poses.data());
    out->weights = weights.is_none() ? nullptr : instance.particle_weights.data();
    out->count = n;
    return 0;
  });
}

int diagnostics(void* p, locsim_diagnostic* out, std::size_t capacity, std::size_t* count,
                char* error, std::size_t size) {
  auto& instance = *static_cast<Instance*>(p);
  *count = 0;
  if (instance.failed.empty() && instance.diagnostics.is_none()) return 0;
  return guarded(instance, error, size, [&] {
    const py::dict values = instance.diagnostics();
    instance.diagnostic_names.clear();
    instance.diagnostic_names.reserve(values.size());
    for (const auto& [key, value] : values) {
      if (*count == capacity) break;
      instance.diagnostic_names.push_back(py::str(key));
      out[*count] = {instance.diagnostic_names.back().c_str(), value.cast<double>()};
      ++*count;
    }
    return 0;
  });
}

int landmark_map(void* p, locsim_landmark_map* out, char* error, std::size_t size) {
  auto& instance = *static_cast<Instance*>(p);
  *out = {nullptr, 0};
  if (instance.failed.empty() && instance.landmark_map.is_none()) return 0;
  return guarded(instance, error, size, [&] {
    const py::tuple result = instance.landmark_map();
    if (result.size() != 3)
      throw std::runtime_error("landmark_map() must return (ids, xy, covariances)");
    const py::array_t<double> ids = numbers(result[0]), xy = numbers(result[1]),
                              cov = numbers(result[2]);
    const auto n = static_cast<std::size_t>(ids.size());
    if (static_cast<std::size_t>(xy.size()) != 2 * n ||
        static_cast<std::size_t>(cov.size()) != 4 * n)
      throw std::runtime_error("landmark_map(): ids (N,), xy (N, 2) and covariances (N, 2, 2)");
    instance.mapped.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      locsim_mapped_landmark& m = instance.mapped[i];
      m.id = static_cast<std::int32_t>(ids.data()[i]);
      m.x = xy.data()[2 * i], m.y = xy.data()[2 * i + 1];
      std::memcpy(m.covariance, cov.data() + 4 * i, sizeof m.covariance);
    }
    *out = {instance.mapped.data(), n};
    return 0;
  });
}

// One create function per script: the ABI's create takes no context, so each script's table
// points at its own.
template <std::size_t K>
void* create_k(const locsim_init* init, char* error, std::size_t size) {
  return create_instance(*scripts().at(K), init, error, size);
}
template <std::size_t... K>
constexpr std::array<void* (*)(const locsim_init*, char*, std::size_t), sizeof...(K)> creators(
    std::index_sequence<K...>) {
  return {&create_k<K>...};
}
constexpr auto kCreators = creators(std::make_index_sequence<kMaxScripts>{});

void* create_without_script(const locsim_init*, char* error, std::size_t size) {
  write_error(error, size,
              "the python plugin runs a script: --localizer python:FILE.py (or NAME, for NAME.py "
              "in the plugin path); docs/python.md");
  return nullptr;
}

const locsim_localizer* load(const char* source, char* error, std::size_t size) {
  const std::string path = source;
  for (const auto& script : scripts())
    if (script->path == path) return &script->table;
  if (scripts().size() == kMaxScripts) {
    write_error(
        error, size,
        "more than " + std::to_string(kMaxScripts) + " Python localizer scripts in one process");
    return nullptr;
  }
  const auto [status, out, err] = run_describe(path);
  if (status != 0) {
    std::string message = err;
    while (!message.empty() && (message.back() == '\n' || message.back() == '\r'))
      message.pop_back();
    if (message.empty())
      message = path + ": " + LOCSIM_PYTHON_EXECUTABLE + " could not read it (exit " +
                std::to_string(status) + ")";
    write_error(error, size, message);
    return nullptr;
  }
  auto script = std::make_unique<Script>();
  script->path = path;
  script->directory = fs::path(path).parent_path().string();
  locsim_localizer& t = script->table;
  t.abi_version = LOCSIM_LOCALIZER_ABI_VERSION;
  t.struct_size = sizeof(locsim_localizer);
  std::stringstream lines(out);
  std::string line;
  while (std::getline(lines, line)) {
    const auto f = split(line, '\t');
    if (f.empty()) continue;
    if (f[0] == "name" && f.size() == 2) {
      t.name = script->keep(f[1]);
    } else if (f[0] == "description" && f.size() == 2) {
      t.description = script->keep(f[1]);
    } else if (f[0] == "class" && f.size() == 2) {
      script->class_name = f[1];
    } else if (f[0] == "readings" && f.size() == 2) {
      t.readings = static_cast<std::uint32_t>(std::stoul(f[1]));
    } else if (f[0] == "param" && f.size() == 7) {
      locsim_param_decl d{};
      d.name = script->keep(f[1]);
      d.type = f[2] == "int"      ? LOCSIM_PARAM_INT
               : f[2] == "bool"   ? LOCSIM_PARAM_BOOL
               : f[2] == "string" ? LOCSIM_PARAM_STRING
                                  : LOCSIM_PARAM_DOUBLE;
      if (d.type == LOCSIM_PARAM_STRING) {
        d.default_string = script->keep(f[3]);
      } else {
        d.default_number = std::stod(f[3]);
      }
      d.min_number = f[4].empty() ? -DBL_MAX : std::stod(f[4]);
      d.max_number = f[5].empty() ? DBL_MAX : std::stod(f[5]);
      d.doc = script->keep(f[6]);
      script->params.push_back(d);
    }
  }
  if (t.name == nullptr || t.description == nullptr || script->class_name.empty()) {
    write_error(error, size, path + ": its description could not be read");
    return nullptr;
  }
  t.params = script->params.empty() ? nullptr : script->params.data();
  t.param_count = script->params.size();
  t.create = kCreators[scripts().size()];
  t.destroy = &destroy;
  t.reset = nullptr;  // the host recreates
  t.update = &update;
  t.estimate = &estimate;
  t.particles = &particles;
  t.diagnostics = &diagnostics;
  t.landmark_map = &landmark_map;
  scripts().push_back(std::move(script));
  return &scripts().back()->table;
}

}  // namespace

extern "C" {

LOCSIM_EXPORT const locsim_localizer* locsim_localizer_entry(uint32_t host_abi_version) {
  if (host_abi_version < LOCSIM_LOCALIZER_ABI_VERSION) return nullptr;
  static const locsim_localizer table = [] {
    locsim_localizer t{};
    t.abi_version = LOCSIM_LOCALIZER_ABI_VERSION;
    t.struct_size = sizeof(locsim_localizer);
    t.name = "python";
    t.description =
        "runs a localizer written in Python: --localizer python:FILE.py (docs/python.md)";
    t.create = &create_without_script;
    t.destroy = &destroy;
    t.update = &update;
    t.estimate = &estimate;
    return t;
  }();
  return &table;
}

LOCSIM_EXPORT const locsim_localizer* locsim_localizer_load(uint32_t host_abi_version,
                                                            const char* source, char* error,
                                                            size_t error_size) {
  if (host_abi_version < LOCSIM_LOCALIZER_ABI_VERSION) {
    write_error(error, error_size, "the python plugin needs localizer ABI version 3");
    return nullptr;
  }
  try {
    return load(source, error, error_size);
  } catch (const std::exception& e) {
    write_error(error, error_size, std::string(source) + ": " + e.what());
    return nullptr;
  }
}

}  // extern "C"
