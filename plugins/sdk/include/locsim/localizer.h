/* locsim localizer plugin ABI.
 *
 * A localizer is a shared library exporting one C function, locsim_localizer_entry, which returns
 * a table of function pointers. Only plain C types cross the boundary, so a plugin built with
 * another compiler or C++ standard library still loads. The host checks the table's ABI version
 * and size before using it; every call returns an error (0 = success) instead of exiting.
 *
 * Units: SI (m, s, rad); angles counter-clockwise; poses in the world frame (x, y, theta);
 * covariances 3x3 row-major over (x, y, theta). Pointers handed to a plugin are valid only for the
 * duration of the call; pointers a plugin hands back must stay valid until its next call.
 */
#ifndef LOCSIM_LOCALIZER_H_
#define LOCSIM_LOCALIZER_H_

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Bumped on any incompatible change of the structs below.
 * 2: odometry says which fields its source measured (ticks, pose, velocity) and carries the
 *    velocity; detections say what they are of (a landmark or another robot); a third camera
 *    kind, the range-bearing sensor. The host still serves plugins built for version 1
 *    (docs/plugins.md, "ABI versions").
 * 3: the table ends with `readings`, the kinds of reading the filter uses. */
#define LOCSIM_LOCALIZER_ABI_VERSION 3u
/* The oldest version a host serves. */
#define LOCSIM_LOCALIZER_ABI_VERSION_OLDEST 1u

#if defined(_WIN32)
#define LOCSIM_EXPORT __declspec(dllexport)
#else
#define LOCSIM_EXPORT __attribute__((visibility("default")))
#endif

typedef struct locsim_pose2 {
  double x, y, theta;
} locsim_pose2;

/* ---- parameters ------------------------------------------------------------------------ */
typedef enum locsim_param_type {
  LOCSIM_PARAM_DOUBLE = 0,
  LOCSIM_PARAM_INT = 1,
  LOCSIM_PARAM_BOOL = 2,
  LOCSIM_PARAM_STRING = 3
} locsim_param_type;

/* A parameter the plugin declares; the host validates users' values against it. */
typedef struct locsim_param_decl {
  const char* name;      /* required, [a-z0-9_]+ */
  int type;              /* locsim_param_type */
  double default_number; /* DOUBLE, INT, BOOL (0 or 1) */
  double min_number;     /* DOUBLE, INT: inclusive range */
  double max_number;
  const char* default_string; /* STRING */
  const char* doc;            /* one line, with the unit */
} locsim_param_decl;

/* A validated value: every declared parameter, defaults filled in, in declaration order. */
typedef struct locsim_param_value {
  const char* name;
  int type;
  double number;
  const char* string; /* STRING only */
} locsim_param_value;

/* ---- what the plugin may know ------------------------------------------------------------- */
typedef struct locsim_landmark {
  int id;
  double x, y; /* [m] */
  double radius_m, height_m;
  const char* color; /* name, or "#rrggbb" */
} locsim_landmark;

typedef struct locsim_beacon {
  int id;
  double x, y, height_m; /* [m] */
} locsim_beacon;

/* Occupancy grid of the static world (never people, never the truth). ROS convention: cell
 * (col, row) covers [origin_x + col * resolution, +resolution) x [origin_y + row * resolution,
 * +resolution); row 0 is the bottom. Values: 0 free, 100 occupied. */
typedef struct locsim_occupancy_grid {
  double origin_x, origin_y, resolution_m;
  int32_t width, height;
  const uint8_t* cells; /* width * height, row-major from row 0 */
} locsim_occupancy_grid;

typedef struct locsim_map {
  const locsim_landmark* landmarks; /* NULL with count 0 for SLAM: landmarks are unknown */
  size_t landmark_count;
  const locsim_beacon* beacons;
  size_t beacon_count;
  locsim_occupancy_grid grid;
} locsim_map;

/* The robot's nominal geometry (what its base believes). */
typedef struct locsim_robot_info {
  double wheel_base_m;
  double wheel_radius_m;
  double footprint_radius_m;
} locsim_robot_info;

typedef struct locsim_init {
  uint32_t struct_size; /* sizeof(locsim_init) as the host built it */
  const locsim_param_value* params;
  size_t param_count;
  const locsim_map* map;
  const locsim_robot_info* robot;
  int32_t initial_pose_known;   /* 0: unknown, localize globally */
  locsim_pose2 initial_pose;    /* when known: the guess, drawn around the truth */
  double initial_covariance[9]; /* of the guess */
  uint64_t seed;                /* for the plugin's own random numbers */
} locsim_init;

/* ---- readings (truth never included) ------------------------------------------------------ */
typedef enum locsim_reading_kind {
  LOCSIM_READING_ODOMETRY = 1,
  LOCSIM_READING_IMU = 2,
  LOCSIM_READING_LANDMARKS = 3,
  LOCSIM_READING_BEACON_RANGES = 4,
  LOCSIM_READING_LASER = 5
} locsim_reading_kind;

/* A kind's bit in locsim_localizer.readings. */
#define LOCSIM_READING_BIT(kind) (1u << (unsigned)(kind))

/* What an odometry reading's source measured (bits of locsim_odometry.fields). */
typedef enum locsim_odometry_field {
  LOCSIM_ODOMETRY_TICKS = 1,   /* left_ticks, right_ticks, meters_per_tick */
  LOCSIM_ODOMETRY_POSE = 2,    /* odom_pose as the base reported it */
  LOCSIM_ODOMETRY_VELOCITY = 4 /* v_mps, omega_radps */
} locsim_odometry_field;

/* The robot's odometry (odom frame = world at t = 0). A simulated base reports its wheel ticks
 * and the pose it dead-reckons from them; a recorded dataset what its robot logged (MRCLAM:
 * velocities only). odom_pose is always valid: without LOCSIM_ODOMETRY_POSE the host integrated
 * it from the velocities (each held from its reading until the next, along an arc: SDK
 * locsim/models.hpp, OdometryTracker). Fields the source lacks are zero. */
typedef struct locsim_odometry {
  int64_t left_ticks, right_ticks; /* cumulative */
  double meters_per_tick;          /* nominal wheel circumference / ticks per revolution */
  locsim_pose2 odom_pose;
  /* ABI 2: */
  uint32_t fields;    /* locsim_odometry_field bits: what the source measured */
  double v_mps;       /* forward velocity from t_s on [m/s] */
  double omega_radps; /* angular velocity from t_s on [rad/s] */
} locsim_odometry;

typedef struct locsim_imu {
  double yaw_rate_radps;
  double accel_x_mps2, accel_y_mps2; /* IMU frame */
  double mount_theta;                /* of the IMU frame in the robot frame [rad] */
} locsim_imu;

typedef enum locsim_camera_kind {
  LOCSIM_CAMERA_PTZ = 0,
  LOCSIM_CAMERA_OMNI = 1,
  LOCSIM_CAMERA_RANGE_BEARING = 2 /* ABI 2: a range-bearing sensor with a field of view */
} locsim_camera_kind;

/* What a detection is of (ABI 2). */
typedef enum locsim_target { LOCSIM_TARGET_LANDMARK = 0, LOCSIM_TARGET_ROBOT = 1 } locsim_target;

typedef struct locsim_detection {
  const char* color;
  int32_t id;         /* landmark id; a robot's index in the world; -1 when not reported */
  double range_m;     /* from the robot frame's origin */
  double bearing_rad; /* robot frame */
  /* ABI 2: */
  int32_t target; /* locsim_target */
} locsim_detection;

typedef struct locsim_landmarks {
  int32_t camera; /* locsim_camera_kind */
  double pan_rad; /* PTZ only */
  const locsim_detection* detections;
  size_t count;
} locsim_landmarks;

typedef struct locsim_beacon_range {
  int32_t receiver, beacon_id;
  double range_m;                /* NaN when no echo came back */
  double receiver_x, receiver_y; /* robot frame [m] */
  double receiver_height_m;
} locsim_beacon_range;

typedef struct locsim_beacon_ranges {
  const locsim_beacon_range* ranges;
  size_t count;
} locsim_beacon_ranges;

typedef struct locsim_laser_scan {
  const float* ranges; /* [m], count of them; range_max means no return */
  const float* angles; /* beam angles in the sensor frame [rad] */
  size_t count;
  locsim_pose2 mount; /* sensor pose in the robot frame */
  double range_min, range_max;
} locsim_laser_scan;

typedef struct locsim_reading {
  uint32_t struct_size; /* sizeof(locsim_reading) as the host built it */
  int32_t kind;         /* locsim_reading_kind */
  double t_s;           /* simulated time */
  union {
    locsim_odometry odometry;
    locsim_imu imu;
    locsim_landmarks landmarks;
    locsim_beacon_ranges beacon_ranges;
    locsim_laser_scan laser;
  } data;
} locsim_reading;

/* ---- what the plugin returns -------------------------------------------------------------- */
typedef struct locsim_estimate {
  locsim_pose2 pose;
  double covariance[9];
} locsim_estimate;

typedef struct locsim_particles {
  const locsim_pose2* poses;
  const double* weights; /* normalised, or NULL for equal weights */
  size_t count;
} locsim_particles;

/* A landmark as a SLAM filter has mapped it. */
typedef struct locsim_mapped_landmark {
  int32_t id;           /* the filter's own numbering */
  double x, y;          /* [m] */
  double covariance[4]; /* 2x2 row-major [m^2] */
} locsim_mapped_landmark;

typedef struct locsim_landmark_map {
  const locsim_mapped_landmark* landmarks;
  size_t count;
} locsim_landmark_map;

typedef struct locsim_diagnostic {
  const char* name; /* e.g. "n_eff", "particles" */
  double value;
} locsim_diagnostic;

/* ---- the table ---------------------------------------------------------------------------- */
/* Every call returning int returns 0 on success, else non-zero with a message written to
 * `error` (at most error_size bytes, NUL-terminated). */
typedef struct locsim_localizer {
  uint32_t abi_version;            /* LOCSIM_LOCALIZER_ABI_VERSION the plugin was built with */
  uint32_t struct_size;            /* sizeof(locsim_localizer) as the plugin was built */
  const char* name;                /* required: [a-z0-9_]+, as used on the command line */
  const char* description;         /* required: one line */
  const locsim_param_decl* params; /* may be NULL with param_count 0 */
  size_t param_count;

  /* required: a new instance, or NULL with an error. */
  void* (*create)(const locsim_init* init, char* error, size_t error_size);
  /* required: frees an instance (never fails). */
  void (*destroy)(void* instance);
  /* optional: back to the initial state with a new init (NULL: the host recreates instead). */
  int (*reset)(void* instance, const locsim_init* init, char* error, size_t error_size);
  /* required: one reading, in time order. Kinds a filter does not use it simply ignores. */
  int (*update)(void* instance, const locsim_reading* reading, char* error, size_t error_size);
  /* required: the current estimate. */
  int (*estimate)(void* instance, locsim_estimate* out, char* error, size_t error_size);
  /* optional: the particle cloud, for rendering. */
  int (*particles)(void* instance, locsim_particles* out, char* error, size_t error_size);
  /* optional: named numbers for metrics (effective sample size, particle count, ...). Writes at
   * most `capacity` entries and their number to *count. */
  int (*diagnostics)(void* instance, locsim_diagnostic* out, size_t capacity, size_t* count,
                     char* error, size_t error_size);
  /* optional: SLAM filters' landmark map (the best particle's, or the filter's mean). */
  int (*landmark_map)(void* instance, locsim_landmark_map* out, char* error, size_t error_size);

  /* Since version 3. The kinds of reading the filter uses, LOCSIM_READING_BIT(kind) or-ed; 0: not
   * said (taken as every kind). The host still delivers every reading; the scorer counts a
   * kidnap as recoverable by what these sensors showed after the landing (docs/experiments.md,
   * "recoverable"). */
  uint32_t readings;
} locsim_localizer;

/* The one exported symbol. Receives the host's ABI version; returns the table (static storage)
 * or NULL when the plugin cannot serve that version. */
typedef const locsim_localizer* (*locsim_localizer_entry_fn)(uint32_t host_abi_version);
#define LOCSIM_LOCALIZER_ENTRY_SYMBOL "locsim_localizer_entry"

/* Optional, for a loader plugin: one that runs filters written in another language (locsim_python
 * runs Python scripts: `--localizer python:my_filter.py`). Given a source file (an absolute path),
 * returns the table of the filter it defines, or NULL with a message naming the file and line in
 * `error`. The table (its name, description, parameters and readings are the source's) lives as
 * long as the library, and each source's table is its own; the host calls
 * locsim_localizer_entry first, as for any plugin, and this only for a spec naming a source.
 * Reading the source must not run it: the host asks in the process that later forks the filters'
 * workers, and a failure of the filter's own code belongs to its create call. Additive: the ABI
 * version is unchanged and plugins without it are unaffected. */
typedef const locsim_localizer* (*locsim_localizer_load_fn)(uint32_t host_abi_version,
                                                            const char* source, char* error,
                                                            size_t error_size);
#define LOCSIM_LOCALIZER_LOAD_SYMBOL "locsim_localizer_load"

#ifdef __cplusplus
}
#endif

#endif /* LOCSIM_LOCALIZER_H_ */
