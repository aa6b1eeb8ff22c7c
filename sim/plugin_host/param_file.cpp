#include "sim/plugin_host/param_file.hpp"

#include <algorithm>
#include <cctype>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>

#include "sim/common/yaml_node.hpp"
#include "sim/plugin_host/plugin_library.hpp"

namespace locsim {

namespace {

constexpr const char* kScalar = "a number, true/false or a string, as on the command line";

ParamFileValue value_of(const std::string& key, const YamlNode& node) {
  if (node.is_null()) node.fail(std::string("no value; expected ") + kScalar);
  if (!node.is_scalar()) node.fail(std::string("expected ") + kScalar + ", got a list or a map");
  return {key, node.as_string(), node.place()};
}

std::string names_of(const std::vector<const locsim_localizer*>& tables) {
  std::set<std::string> names;
  for (const locsim_localizer* table : tables) names.insert(table->name);
  std::string out;
  for (const std::string& name : names) out += (out.empty() ? "" : ", ") + name;
  return out.empty() ? "none given" : out;
}

std::string at(const InputPlace& place) {
  return place.where.str() + ": '" + place.key + "'";
}

}  // namespace

bool declares(const locsim_localizer& table, const std::string& key) {
  for (std::size_t i = 0; i < table.param_count; ++i) {
    if (key == table.params[i].name) return true;
  }
  return false;
}

const ParamFileSection* ParamFile::section(const std::string& plugin) const {
  const auto it = std::find_if(sections.begin(), sections.end(),
                               [&](const ParamFileSection& s) { return s.plugin == plugin; });
  return it == sections.end() ? nullptr : &*it;
}

std::vector<ParamFileValue> values_for(const ParamFile& file, const std::string& plugin) {
  std::vector<ParamFileValue> out = file.common;
  if (const ParamFileSection* own = file.section(plugin)) {
    for (const ParamFileValue& value : own->values) {
      const auto it = std::find_if(out.begin(), out.end(),
                                   [&](const ParamFileValue& v) { return v.key == value.key; });
      if (it == out.end()) {
        out.push_back(value);
      } else {
        *it = value;
      }
    }
  }
  return out;
}

std::string param_file_text(const std::vector<std::pair<std::string, std::string>>& values,
                            const std::vector<std::string>& comment) {
  std::string text;
  for (const std::string& line : comment) text += "# " + line + "\n";
  text += "localizer_params:\n";
  // A word or a number as it is (YAML reads it back as the same scalar); anything else, and a
  // word YAML reads as null, quoted (JSON's escapes are YAML's).
  const auto scalar = [](const std::string& word) {
    const auto plain_char = [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-' ||
             c == '+';
    };
    const bool plain = !word.empty() && std::all_of(word.begin(), word.end(), plain_char) &&
                       (std::isalnum(static_cast<unsigned char>(word[0])) ||
                        (word.size() > 1 && std::isdigit(static_cast<unsigned char>(word[1])))) &&
                       word != "null" && word != "Null" && word != "NULL";
    return plain ? word : nlohmann::json(word).dump();
  };
  for (const auto& [key, value] : values) text += "  " + scalar(key) + ": " + scalar(value) + "\n";
  return text;
}

ParamFile load_param_file(const std::filesystem::path& file) {
  const YamlNode root = YamlNode::load_file(file);
  if (!root.is_map()) root.fail("expected a map with a 'localizer_params' key");
  const YamlNode params = root["localizer_params"];
  if (!params.is_map()) {
    params.fail(
        "expected a map of parameter values (and of plugins' names to maps of their values)");
  }
  ParamFile out;
  out.path = file;
  for (const auto& [key, node] : params.entries()) {
    if (!node.is_map()) {
      out.common.push_back(value_of(key, node));
      continue;
    }
    ParamFileSection section{key, node.place(), {}};
    for (const auto& [name, value] : node.entries())
      section.values.push_back(value_of(name, value));
    out.sections.push_back(std::move(section));
  }
  return out;
}

std::vector<std::string> param_file_warnings(const ParamFile& file,
                                             const std::vector<const locsim_localizer*>& tables) {
  std::vector<std::string> warnings;
  // A file written for several filters (calibrate's) holds each one's keys: a key this run's
  // localizers do not declare is only worth a warning when no plugin found declares it either
  // (a misspelt name). The other plugins are loaded only when such a key is there.
  std::optional<std::set<std::string>> declared_elsewhere;
  const auto declared_by_another_plugin = [&](const std::string& key) {
    if (!declared_elsewhere) {
      declared_elsewhere.emplace();
      for (const std::filesystem::path& plugin : list_plugin_files()) {
        try {
          const PluginLibrary library(plugin);
          const locsim_localizer& t = library.table();
          for (std::size_t i = 0; i < t.param_count; ++i)
            declared_elsewhere->insert(t.params[i].name);
        } catch (const PluginError&) {
          // A plugin that does not load declares nothing; `locsim plugins` says why.
        }
      }
    }
    return declared_elsewhere->count(key) > 0;
  };
  for (const ParamFileValue& value : file.common) {
    const bool used = std::any_of(tables.begin(), tables.end(), [&](const locsim_localizer* t) {
      return declares(*t, value.key);
    });
    if (!used && !declared_by_another_plugin(value.key)) {
      warnings.push_back(at(value.place) + " is declared by no plugin found (this run's: " +
                         names_of(tables) + "; `locsim plugins` lists them all): ignored");
    }
  }
  for (const ParamFileSection& section : file.sections) {
    const bool ran = std::any_of(tables.begin(), tables.end(), [&](const locsim_localizer* t) {
      return section.plugin == t->name;
    });
    if (ran) continue;
    try {
      find_plugin(section.plugin);  // a plugin not run here, but there is one of that name
    } catch (const PluginError&) {
      warnings.push_back(at(section.place) + " names no plugin found (`locsim plugins` lists " +
                         "them; this run's: " + names_of(tables) + "): ignored");
    }
  }
  return warnings;
}

}  // namespace locsim
