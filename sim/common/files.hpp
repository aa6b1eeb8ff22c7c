// Whole-file reads and writes, every write checked: a file that cannot be written is an error
// naming the path and the system's reason, never a silently short file.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace locsim {

/// The file's bytes. Throws std::runtime_error naming the path and the reason.
std::string read_text(const std::filesystem::path& file);

/// An input file's bytes (a world, scenario, experiment or map). Throws InputError naming the
/// file when it does not exist, is a directory, cannot be read (with the system's reason) or is
/// larger than `max_bytes` (checked before anything is read).
std::string read_input_file(const std::filesystem::path& file, std::uintmax_t max_bytes);

/// Writes `content` to `file` (replacing it). Throws std::runtime_error naming the path and the
/// system's reason when it cannot be written whole.
void write_file(const std::filesystem::path& file, std::string_view content);

/// Writes through a temporary file and a rename: a reader never sees half a file.
void write_json_atomically(const std::filesystem::path& file,
                           const nlohmann::ordered_json& content);

}  // namespace locsim
