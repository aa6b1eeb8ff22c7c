// `locsim generate`: write generated worlds, one per seed.
#include <charconv>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <system_error>
#include <tuple>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "common.hpp"
#include "sim/common/errors.hpp"
#include "sim/common/files.hpp"
#include "sim/world/generator.hpp"

namespace locsim::cli::generate_cmd {

/// What the command line gives; its options write into it, so it lives as long as the command.
struct State {
  GeneratorDef def;
  std::string out, seeds = "1", landing = "alternate";
  // Count knobs as given ("N" or "A-B"); empty: drawn in the family's range.
  std::string landmarks, obstacles, people, slippery;
  bool overwrite = false, quiet = false, no_beacons = false, no_imu = false;
};

int execute(State& s) {
  std::uint64_t first = 0, last = 0;
  {
    const std::string& text = s.seeds;
    const auto dash = text.find('-');
    const auto parse = [&](std::string_view part, std::uint64_t& out) {
      const auto [end, ec] = std::from_chars(part.data(), part.data() + part.size(), out);
      return ec == std::errc() && end == part.data() + part.size() && !part.empty();
    };
    const bool ok = dash == std::string::npos
                        ? parse(text, first) && (last = first, true)
                        : parse(std::string_view(text).substr(0, dash), first) &&
                              parse(std::string_view(text).substr(dash + 1), last);
    if (!ok || last < first || last - first >= 10000)
      throw InputError("--seeds: expected N or A-B (A <= B, at most 10000 seeds), got '" + text +
                       "'");
  }
  GeneratorDef& def = s.def;
  for (const auto& [text, knob, option] : {std::tuple{&s.landmarks, &def.landmarks, "--landmarks"},
                                           {&s.obstacles, &def.obstacles, "--obstacles"},
                                           {&s.people, &def.people, "--people"},
                                           {&s.slippery, &def.slippery, "--slippery"}}) {
    if (!text->empty()) *knob = CountKnob::parse(*text, option);
  }
  def.beacons = !s.no_beacons;
  def.imu = !s.no_imu;
  def.landing = *landing_from_name(s.landing);  // CLI checked it
  const std::filesystem::path out(s.out);
  if (out.empty()) throw InputError("--out: the path is empty");
  check_output_folder(out, "--out");
  // Every world first, then the files: a knob that fails fails before anything is written.
  std::vector<std::pair<std::filesystem::path, GeneratedWorld>> worlds;
  for (std::uint64_t seed = first;; ++seed) {
    def.seed = seed;
    const std::filesystem::path file =
        out / (def.family + "_seed" + std::to_string(seed) + ".yaml");
    if (!s.overwrite && std::filesystem::exists(file))
      throw InputError("--out: " + file.string() + " exists (pass --overwrite to replace it)");
    worlds.emplace_back(file, generate_world(def));
    if (seed == last) break;
  }
  make_output_folder(out, "--out");
  for (const auto& [file, world] : worlds) {
    write_file(file, world.yaml);
    if (!s.quiet) {
      std::printf("%s\n", file.c_str());
      for (const std::string& note : world.notes) std::printf("  note: %s\n", note.c_str());
    }
  }
  return kExitOk;
}

}  // namespace locsim::cli::generate_cmd

namespace locsim::cli {

Command add_generate(CLI::App& app) {
  const auto state = std::make_shared<generate_cmd::State>();
  GeneratorDef& def = state->def;
  CLI::App* const generate =
      app.add_subcommand("generate",
                         "Write generated worlds: a family (room, corridor, office) drawn from "
                         "each seed and a few knobs, "
                         "with a drive loop and kidnaps (docs/worlds.md#generated-worlds)");
  generate->add_option("family", def.family, "room, corridor or office")
      ->required()
      ->check(CLI::IsMember(generator_families()));
  generate->add_option("--out", state->out, "Folder for FAMILY_seedN.yaml")->required();
  generate->add_option("--seeds", state->seeds, "A seed N, or a range A-B (one world each)")
      ->capture_default_str();
  const auto count_option = [generate](const char* name, std::string& value, const char* what) {
    generate->add_option(name, value, what)->type_name("N|A-B");
  };
  generate
      ->add_option(
          "--length", def.length_m,
          "Room: x extent (default drawn in 8-20); corridor: length (20-40); office: 16-30 [m]")
      ->check(number_in(GeneratorDef::kSizeRange.min, GeneratorDef::kSizeRange.max));
  generate
      ->add_option(
          "--width", def.width_m,
          "Room: y extent (default drawn in 6-12); corridor: width (2-3); office: 9-14 [m]")
      ->check(number_in(GeneratorDef::kSizeRange.min, GeneratorDef::kSizeRange.max));
  count_option("--landmarks", state->landmarks,
               "Landmarks (default: room 4-8 along the walls, corridor 3, office one per 1-2 "
               "rooms + 2); A-B: drawn per seed, as every count");
  generate->add_flag("--landmarks-anywhere", def.landmarks_anywhere,
                     "Room: landmarks standing free, not along the walls");
  count_option("--obstacles", state->obstacles,
               "Pillars and cabinets (default: room 2-5, corridor 2-4, office 3-8)");
  count_option("--people", state->people,
               "People walking, who shove the robot aside (default 1-3; a crowd: 5-20)");
  count_option("--slippery", state->slippery, "Slippery floor patches on the path (0-2)");
  generate->add_flag("--no-beacons", state->no_beacons, "No ultrasonic beacons");
  generate->add_flag("--no-imu", state->no_imu,
                     "A robot without an IMU (the wheels alone tell its turns)");
  generate->add_option("--kidnaps", def.kidnaps, "Kidnaps (default 2)")
      ->transform(whole_number_in(0, 100));
  generate->add_flag("--quick-kidnaps", def.quick_kidnaps,
                     "The second kidnap 3-6 s after the first lands");
  generate
      ->add_option("--landing", state->landing,
                   "Where kidnaps land: alternate (in view, blind, ...), in_view, blind, any")
      ->check(CLI::IsMember({"alternate", "in_view", "blind", "any"}))
      ->capture_default_str();
  generate->add_option("--duration", def.duration_s, "Scenario length [s]")
      ->check(number_in(GeneratorDef::kDurationRange.min, GeneratorDef::kDurationRange.max))
      ->capture_default_str();
  generate->add_flag("--overwrite", state->overwrite, "Replace existing world files");
  generate->add_flag("-q,--quiet", state->quiet, "No list of the files written");
  return {generate, [state] { return generate_cmd::execute(*state); }};
}

}  // namespace locsim::cli
