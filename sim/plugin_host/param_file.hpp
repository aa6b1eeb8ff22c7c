// Localizer parameter files (`--params FILE`, an experiment's `params_file:`): values for the
// parameters the localizer plugins declare, common to every plugin or for one plugin by name.
// What `locsim calibrate` writes is one: only `localizer_params` is read, other top-level keys
// are left to their readers. ParamSet applies a file below the `--localizer` spec's own values.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "locsim/localizer.h"
#include "sim/common/errors.hpp"

namespace locsim {

/// One value of the file, as its text reads on the command line ("0.05", "true", "fast").
struct ParamFileValue {
  std::string key;
  std::string text;
  InputPlace place;  // file:line:col and `localizer_params[.PLUGIN].KEY`, for messages
};

/// A `localizer_params:` map under a plugin's name: values for that plugin only.
struct ParamFileSection {
  std::string plugin;  // the plugin's declared name (its table's `name`), e.g. ekf_landmarks
  InputPlace place;
  std::vector<ParamFileValue> values;  // in file order
};

struct ParamFile {
  std::filesystem::path path;
  std::vector<ParamFileValue> common;      // for every plugin that declares them, in file order
  std::vector<ParamFileSection> sections;  // in file order

  /// The section of the plugin named `plugin`, or null.
  const ParamFileSection* section(const std::string& plugin) const;
};

/// The values the plugin named `plugin` takes from `file`: the common ones, then its section's
/// (one replaces a common value of the same key), in file order.
std::vector<ParamFileValue> values_for(const ParamFile& file, const std::string& plugin);

/// A parameter file's text: `values` (key, text) as common values, after `comment` (lines
/// without their "# "), so that load_param_file reads them back as given.
std::string param_file_text(const std::vector<std::pair<std::string, std::string>>& values,
                            const std::vector<std::string>& comment);

/// Whether the plugin of `table` declares a parameter named `key`.
bool declares(const locsim_localizer& table, const std::string& key);

/// Reads `file`: a map with a `localizer_params` map of scalars (common values) and maps of
/// scalars (a plugin's section). Throws InputError naming file:line:col and the key.
ParamFile load_param_file(const std::filesystem::path& file);

/// What in `file` no localizer of a run uses, most likely a typo (each a message without the
/// "warning" prefix): a common key that none of `tables` declares, and a section that names
/// neither one of `tables` nor a plugin found in the search path. Not errors: a file written for
/// many plugins (calibrate's) is meant to be used with any of them.
std::vector<std::string> param_file_warnings(const ParamFile& file,
                                             const std::vector<const locsim_localizer*>& tables);

}  // namespace locsim
