// The ROS 2 message types locsim reads and writes, defined as ROS 2 Humble and Jazzy define them
// (their fields, in order; the two releases agree on every one here). `import rosbag2` falls back
// on them for a bag that carries no definitions (Humble's SQLite bags), `export --rosbag2` writes
// them as its schemas.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace locsim::rosbag {

/// The .msg text of one type ("pkg/msg/Type" or "pkg/Type"), the types it uses named pkg/Type;
/// empty when locsim does not know the type.
std::string_view known_definition(std::string_view type_name);

/// A type's schema as rosbag2 writes it: its text, then each type it uses (depth first, once) after
/// a line of 80 '=' and "MSG: pkg/Type". Throws std::invalid_argument for a type not known.
std::string schema_text(std::string_view type_name);

/// Every type known_definition() knows, as "pkg/msg/Type".
std::vector<std::string> known_types();

}  // namespace locsim::rosbag
