// ROS 2 bags: CDR, message definitions, MCAP and SQLite storage (sim/rosbag). What we write is
// checked by an independent reader and decoder (tests/checkers: npm's @mcap/core and
// @foxglove/rosmsg2-serialization, installed by tools/setup), and we read what it writes.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <bit>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "sim/common/errors.hpp"
#include "sim/rosbag/bag.hpp"
#include "sim/rosbag/cdr.hpp"
#include "sim/rosbag/mcap.hpp"
#include "sim/rosbag/message_definition.hpp"
#include "sim/rosbag/ros_types.hpp"
#include "test_support.hpp"

namespace locsim::rosbag {
namespace {

namespace fs = std::filesystem;
using locsim::testing::expect_contains;
using locsim::testing::Outcome;
using locsim::testing::run_command;
using locsim::testing::temp_dir;
using nlohmann::json;

std::string read_file(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

void write_bytes(const fs::path& file, std::string_view bytes) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// ---- a message as the checkers print it (JSON), to and from CDR by a definition ----------------

/// A number as the checkers print it: JSON numbers, bools, and strings for what JSON cannot hold
/// ("NaN", "Infinity", "-Infinity", "-0") and for 64-bit integers (decimal).
double json_number(const json& value) {
  if (value.is_boolean()) return value.get<bool>() ? 1.0 : 0.0;
  if (value.is_number()) return value.get<double>();
  const std::string text = value.get<std::string>();
  return std::strtod(text.c_str(), nullptr);  // NaN, Infinity, -0 and decimals alike
}

/// Same numbers bit for bit (NaN equal to NaN, -0 not equal to 0).
bool same_number(double a, double b) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

/// Our decoded message against the checkers' JSON of it, field by field.
void expect_same(const Value& ours, const json& theirs, const std::string& path) {
  switch (ours.kind()) {
    case Value::Kind::kNumber:
      EXPECT_TRUE(same_number(ours.number(), json_number(theirs)))
          << path << ": " << ours.number() << " vs " << theirs.dump();
      return;
    case Value::Kind::kString:
      EXPECT_EQ(ours.string(), theirs.get<std::string>()) << path;
      return;
    case Value::Kind::kNumbers:
      ASSERT_EQ(ours.numbers().size(), theirs.size()) << path;
      for (std::size_t i = 0; i < theirs.size(); ++i) {
        EXPECT_TRUE(same_number(ours.numbers()[i], json_number(theirs[i])))
            << path << "[" << i << "]: " << ours.numbers()[i] << " vs " << theirs[i].dump();
      }
      return;
    case Value::Kind::kList:
      ASSERT_EQ(ours.items().size(), theirs.size()) << path;
      for (std::size_t i = 0; i < theirs.size(); ++i) {
        expect_same(ours.items()[i], theirs[i], path + "[" + std::to_string(i) + "]");
      }
      return;
    case Value::Kind::kMessage: {
      const auto& fields = ours.type()->fields;
      ASSERT_EQ(fields.size(), theirs.size()) << path << ": " << theirs.dump();
      for (std::size_t f = 0; f < fields.size(); ++f) {
        ASSERT_TRUE(theirs.contains(fields[f].name)) << path << "." << fields[f].name;
        expect_same(ours.items()[f], theirs.at(fields[f].name), path + "." + fields[f].name);
      }
      return;
    }
  }
}

// ---- CDR ---------------------------------------------------------------------------------------

TEST(Cdr, AlignsEachNumberToItsSizeFromTheEndOfTheHeader) {
  CdrWriter out;
  out.write(std::uint8_t{7});
  out.write(1.5);  // 7 bytes of padding before it
  out.write(std::int16_t{-3});
  out.write_string("ab");       // uint32 3, 'a', 'b', NUL
  out.write(std::uint32_t{9});  // 3 bytes after the string, then 1 byte of padding
  const std::string& bytes = out.bytes();
  ASSERT_EQ(bytes.size(), 4u + 1 + 7 + 8 + 2 + 2 + 4 + 3 + 1 + 4);
  EXPECT_EQ(bytes.substr(0, 4), std::string("\x00\x01\x00\x00", 4));

  CdrReader in(bytes);
  EXPECT_EQ(in.read<std::uint8_t>(), 7);
  EXPECT_EQ(in.read<double>(), 1.5);
  EXPECT_EQ(in.read<std::int16_t>(), -3);
  EXPECT_EQ(in.read_string(), "ab");
  EXPECT_EQ(in.read<std::uint32_t>(), 9u);
  EXPECT_EQ(in.remaining(), 0u);
}

TEST(Cdr, ReadsBigEndianMessages) {
  // Header 0x00 0x00: big-endian. An int32 then a float64, aligned to 8 after the header.
  std::string bytes("\x00\x00\x00\x00", 4);
  bytes += std::string("\xff\xff\xff\xfe", 4) + std::string(4, '\0');
  bytes += std::string("\x40\x09\x21\xfb\x54\x44\x2d\x18", 8);  // pi
  CdrReader in(bytes);
  EXPECT_FALSE(in.little_endian());
  EXPECT_EQ(in.read<std::int32_t>(), -2);
  EXPECT_EQ(in.read<double>(), 3.141592653589793);
}

TEST(Cdr, RefusesAMessageCutShortOrACountItCannotHoldNamingTheByte) {
  CdrWriter out;
  out.write(std::uint32_t{1});
  out.write_count(1000000);  // a sequence of a million doubles, and no bytes for them
  CdrReader in(out.bytes());
  in.read<std::uint32_t>();
  try {
    in.read_count(8);
    FAIL() << "a count past the end was read";
  } catch (const CdrError& e) {
    expect_contains(e.what(), "byte 8: a sequence of 1000000 elements cannot fit");
  }
  EXPECT_THROW(CdrReader(std::string("\x00\x01", 2)), CdrError);
  EXPECT_THROW(CdrReader(std::string("\x00\x03\x00\x00", 4)), CdrError);  // parameter list
  // The reader looks at the bytes it is given: they must outlive it.
  const std::string short_bytes(
      "\x00\x01\x00\x00\x10\x00\x00\x00"
      "ab",
      10);
  CdrReader short_string(short_bytes);
  try {
    short_string.read_string();
    FAIL();
  } catch (const CdrError& e) {
    expect_contains(e.what(), "byte 8: a string of 16 bytes runs past the message's end");
  }
}

// ---- message definitions -----------------------------------------------------------------------

// A definition with what real ones have: comments, constants, defaults, bounded and fixed arrays,
// a type of the same package, a pkg/msg/Type name, and an empty message.
constexpr std::string_view kDefinition =
    "# a comment\n"
    "int32 LIMIT=10   # a constant takes no bytes\n"
    "string NAME = \"a # not a comment\"\n"
    "bool flag true\n"
    "uint8[3] rgb [1, 2, 3]\n"
    "float64[<=4] weights\n"
    "string<=8 label \"x#y\"\n"
    "Part[] parts\n"
    "test_pkg/msg/Empty nothing\n"
    "builtin_interfaces/Time stamp\n"
    "int64 big\n"
    "\n"
    "================================================================================\n"
    "MSG: test_pkg/Part\n"
    "string name\n"
    "float32[2] xy\n"
    "Empty[] empties\n"
    "================================================================================\n"
    "MSG: test_pkg/Empty\n"
    "# only a comment: CDR holds one placeholder byte\n";

TEST(MessageDefinition, ParsesWhatABagCarriesAndDecodesByIt) {
  const MessageDefinition definition("test_pkg/msg/Thing", kDefinition);
  ASSERT_EQ(definition.name(), "test_pkg/Thing");
  ASSERT_EQ(definition.types().size(), 4u);  // Thing, Part, Empty, Time (locsim's own)
  const TypeDefinition& thing = definition.types()[0];
  ASSERT_EQ(thing.fields.size(), 8u);
  EXPECT_EQ(thing.fields[0].name, "flag");
  EXPECT_EQ(thing.fields[1].shape, FieldDefinition::Shape::kFixedArray);
  EXPECT_EQ(thing.fields[1].length, 3u);
  EXPECT_EQ(thing.fields[2].shape, FieldDefinition::Shape::kSequence);
  EXPECT_EQ(thing.fields[2].length, 4u);
  EXPECT_EQ(thing.fields[3].type, FieldType::kString);
  EXPECT_EQ(thing.fields[4].message_type, "test_pkg/Part");
  EXPECT_EQ(thing.fields[5].message_type, "test_pkg/Empty");
  EXPECT_EQ(thing.fields[6].message_type, "builtin_interfaces/Time");

  const json message = {{"flag", true},
                        {"rgb", {1, 2, 250}},
                        {"weights", {0.5, -0.25}},
                        {"label", "hi"},
                        {"parts",
                         {{{"name", "a"},
                           {"xy", {1.5, -2.0}},
                           {"empties", json::array({json::object(), json::object()})}},
                          {{"name", ""}, {"xy", {0.0, 3.25}}, {"empties", json::array()}}}},
                        {"nothing", json::object()},
                        {"stamp", {{"sec", 1700000000}, {"nanosec", 999999999}}},
                        {"big", "-9007199254740993"}};
  const std::string bytes = definition.encode(message);
  const Value decoded = definition.decode(bytes);
  expect_same(decoded, message, "Thing");
  EXPECT_EQ(decoded.number("stamp.nanosec"), 999999999.0);
  EXPECT_EQ(decoded.at("parts").items()[0].string("name"), "a");
  EXPECT_EQ(decoded.find("parts.name"), nullptr);  // a list has no fields
  EXPECT_THROW(decoded.at("no_such_field"), std::out_of_range);

  // Every byte cut off makes a message that is refused, never one read past its end.
  for (std::size_t keep = 0; keep + 1 < bytes.size(); ++keep) {
    EXPECT_THROW(definition.decode(std::string_view(bytes).substr(0, keep)), CdrError) << keep;
  }
  // JSON that does not fit the definition is refused naming the field.
  json wrong = message;
  wrong["parts"][1].erase("xy");
  try {
    definition.encode(wrong);
    FAIL();
  } catch (const std::invalid_argument& e) {
    expect_contains(e.what(), "test_pkg/Thing.parts[1].xy: missing");
  }
  wrong = message;
  wrong["rgb"] = {1, 2};
  EXPECT_THROW(definition.encode(wrong), std::invalid_argument);
}

TEST(MessageDefinition, RefusesWhatCannotBeReadNamingTheTypeAndLine) {
  const auto message = [](std::string_view type, std::string_view text) -> std::string {
    try {
      MessageDefinition definition(type, text);
    } catch (const DefinitionError& e) {
      return e.what();
    }
    return "(accepted)";
  };
  expect_contains(message("p/msg/A", "int32 x\nfloat64[abc] y\n"),
                  "the definition of p/msg/A line 2: 'abc' is not an array length");
  expect_contains(message("p/msg/A", "int32\n"), "line 1: 'int32' is a type without a name");
  expect_contains(message("p/msg/A", "int32 x\nother_pkg/Unknown u\n"),
                  "p/A uses other_pkg/Unknown, which neither the bag defines nor locsim knows");
  expect_contains(message("p/msg/A", "B b\n===\nMSG: p/B\nA a\n"), "p/B.a holds p/A inside itself");
  expect_contains(message("p/msg/A", "int32 x\n=====\nint32 y\n"),
                  "a separator not followed by 'MSG: pkg/Type'");
  expect_contains(message("A", "int32 x\n"), "not pkg/Type or pkg/msg/Type");
  // A sequence of itself is a tree, and fine.
  EXPECT_EQ(message("p/msg/Tree", "Tree[] children\nint32 v\n"), "(accepted)");
}

TEST(MessageDefinition, KnowsEveryTypeItWritesAsTheSchemaABagCarries) {
  const std::vector<std::string> types = known_types();
  ASSERT_GE(types.size(), 20u);
  for (const std::string& type : types) {
    SCOPED_TRACE(type);
    const MessageDefinition known = MessageDefinition::known(type);
    // The schema text a bag carries, read back alone, is the same definition.
    const MessageDefinition carried(type, schema_text(type));
    ASSERT_EQ(known.types().size(), carried.types().size());
    for (std::size_t i = 0; i < known.types().size(); ++i) {
      EXPECT_EQ(known.types()[i].name, carried.types()[i].name);
      ASSERT_EQ(known.types()[i].fields.size(), carried.types()[i].fields.size());
    }
  }
  const MessageDefinition scan = MessageDefinition::known("sensor_msgs/msg/LaserScan");
  EXPECT_EQ(scan.types()[0].fields.back().name, "intensities");
  EXPECT_THROW(schema_text("sensor_msgs/msg/PointCloud2"), std::invalid_argument);
}

// ---- MCAP --------------------------------------------------------------------------------------

struct Written {
  std::uint16_t channel;
  std::uint64_t time_ns;
  std::string data;
};

/// Writes three channels of messages of all sizes, small chunks so that there are many.
std::vector<Written> write_sample(const fs::path& file, McapCompression compression,
                                  bool crcs = true) {
  McapWriterOptions options;
  options.compression = compression;
  options.crcs = crcs;
  options.chunk_bytes = 4096;
  McapWriter writer(file, options);
  const std::uint16_t schema = writer.add_schema("std_msgs/msg/String", "ros2msg", "string data\n");
  const std::uint16_t a =
      writer.add_channel(schema, "/a", "cdr", {{"offered_qos_profiles", "- x"}});
  const std::uint16_t b = writer.add_channel(schema, "/b", "cdr");
  const std::uint16_t c = writer.add_channel(0, "/raw", "");  // a channel without a schema
  std::vector<Written> written;
  for (int i = 0; i < 300; ++i) {
    CdrWriter message;
    message.write_string(
        std::string(static_cast<std::size_t>(i * 7 % 500), static_cast<char>('a' + i % 26)));
    const std::uint16_t channel = i % 3 == 0 ? a : i % 3 == 1 ? b : c;
    const std::uint64_t time_ns =
        1'700'000'000'000'000'000ull + static_cast<std::uint64_t>(i) * 1000;
    writer.write(channel, static_cast<std::uint32_t>(i), time_ns, time_ns - 5, message.bytes());
    written.push_back({channel, time_ns, message.bytes()});
  }
  writer.finish();
  return written;
}

TEST(Mcap, ReadsBackWhatItWritesInEveryCompression) {
  const fs::path dir = temp_dir("mcap");
  for (const McapCompression compression :
       {McapCompression::kNone, McapCompression::kZstd, McapCompression::kLz4}) {
    const fs::path file =
        dir / ("sample_" + std::to_string(static_cast<int>(compression)) + ".mcap");
    const std::vector<Written> written = write_sample(file, compression);
    McapReader reader(file);
    EXPECT_EQ(reader.profile(), "ros2");
    std::size_t i = 0;
    reader.read([&](const McapChannel& channel, const McapSchema* schema, const McapMessage& m) {
      ASSERT_LT(i, written.size());
      EXPECT_EQ(m.channel_id, written[i].channel);
      EXPECT_EQ(channel.id, written[i].channel);
      EXPECT_EQ(m.sequence, i);
      EXPECT_EQ(m.log_time_ns, written[i].time_ns);
      EXPECT_EQ(m.publish_time_ns, written[i].time_ns - 5);
      EXPECT_EQ(m.data, written[i].data);
      EXPECT_TRUE(m.in_chunk);
      EXPECT_EQ(schema == nullptr, channel.topic == "/raw");
      ++i;
    });
    EXPECT_EQ(i, written.size());
    EXPECT_TRUE(reader.complete());
    ASSERT_EQ(reader.channels().size(), 3u);
    EXPECT_EQ(reader.channels().at(0).metadata,
              (std::vector<std::pair<std::string, std::string>>{{"offered_qos_profiles", "- x"}}));
    EXPECT_EQ(reader.schemas().at(1).data, "string data\n");
  }
  // Compressed, the repetitive sample is several times smaller.
  EXPECT_LT(fs::file_size(dir / "sample_1.mcap") * 4, fs::file_size(dir / "sample_0.mcap"));
  EXPECT_LT(fs::file_size(dir / "sample_2.mcap") * 3, fs::file_size(dir / "sample_0.mcap"));
}

TEST(Mcap, RefusesACorruptOrCutShortFileNamingTheByteAndKeepsWhatCameBefore) {
  const fs::path dir = temp_dir("corrupt");
  const fs::path good = dir / "good.mcap";
  write_sample(good, McapCompression::kZstd);
  const std::string bytes = read_file(good);
  const auto read_all = [](const fs::path& file, std::size_t& delivered) -> std::string {
    delivered = 0;
    try {
      McapReader reader(file);
      reader.read([&](const McapChannel&, const McapSchema*, const McapMessage&) { ++delivered; });
    } catch (const McapError& e) {
      return e.what();
    }
    return "(read)";
  };
  std::size_t delivered = 0;

  // Cut in the middle: the chunks before the cut are read, then the reader says where it stopped.
  const fs::path cut = dir / "cut.mcap";
  write_bytes(cut, std::string_view(bytes).substr(0, bytes.size() / 2));
  std::string error = read_all(cut, delivered);
  expect_contains(error, cut.string() + ": byte ");
  expect_contains(error, "(a recording cut short");
  EXPECT_GT(delivered, 50u);
  EXPECT_LT(delivered, 300u);

  // A byte flipped inside a compressed chunk: zstd or the chunk's CRC says so.
  std::string flipped = bytes;
  const std::size_t chunk = bytes.find(std::string("zstd", 4));
  ASSERT_NE(chunk, std::string::npos);
  flipped[chunk + 40] = static_cast<char>(flipped[chunk + 40] ^ 0x10);
  write_bytes(dir / "flipped.mcap", flipped);
  error = read_all(dir / "flipped.mcap", delivered);
  EXPECT_TRUE(error.find("CRC does not match") != std::string::npos ||
              error.find("zstd cannot decompress") != std::string::npos)
      << error;
  expect_contains(error, "(chunk, op 0x06)");

  // An unknown compression, a record longer than the file, no magic.
  std::string bz2 = bytes;
  bz2.replace(chunk, 4, "bz2?");
  write_bytes(dir / "bz2.mcap", bz2);
  expect_contains(read_all(dir / "bz2.mcap", delivered),
                  "compressed with 'bz2?', which locsim does not read (zstd, lz4 or none)");
  // The first record after the header is the schema: its length's high byte made huge.
  const std::size_t schema_at = bytes.find("std_msgs/msg/String") - 2 - 4 - 9;
  ASSERT_EQ(bytes[schema_at], '\x03');
  std::string long_record = bytes;
  long_record[schema_at + 8] = '\x7f';
  write_bytes(dir / "long.mcap", long_record);
  expect_contains(read_all(dir / "long.mcap", delivered), "run past the file's end");
  write_bytes(dir / "text.mcap", "not an MCAP file at all, just text");
  expect_contains(read_all(dir / "text.mcap", delivered), "not an MCAP file (no magic at byte 0)");
}

// ---- bags: folders, MCAP and SQLite files ------------------------------------------------------

std::string metadata_yaml(const std::string& storage, const std::vector<std::string>& files) {
  std::string text =
      "rosbag2_bagfile_information:\n"
      "  version: 5\n"
      "  storage_identifier: " +
      storage +
      "\n"
      "  relative_file_paths:\n";
  for (const std::string& file : files) text += "    - " + file + "\n";
  text +=
      "  topics_with_message_count:\n"
      "    - topic_metadata:\n"
      "        name: /a\n"
      "        type: std_msgs/msg/String\n"
      "        serialization_format: cdr\n"
      "        offered_qos_profiles: \"- history: 1\"\n"
      "      message_count: 100\n"
      "  compression_format: \"\"\n"
      "  compression_mode: \"\"\n";
  return text;
}

/// A rosbag2 SQLite file as Humble writes one (no message_definitions table).
void write_sqlite_bag(const fs::path& file, int messages) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  const auto exec = [&](const std::string& sql) {
    char* error = nullptr;
    ASSERT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error), SQLITE_OK) << error;
  };
  exec("CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL)");
  exec(
      "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL, "
      "serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL)");
  exec(
      "CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, "
      "timestamp INTEGER NOT NULL, data BLOB NOT NULL)");
  exec("INSERT INTO topics VALUES (1, '/chatter', 'std_msgs/msg/String', 'cdr', '- depth: 10')");
  sqlite3_stmt* insert = nullptr;
  ASSERT_EQ(
      sqlite3_prepare_v2(db, "INSERT INTO messages(topic_id, timestamp, data) VALUES (1, ?, ?)", -1,
                         &insert, nullptr),
      SQLITE_OK);
  // Inserted newest first: the reader gives them in time order.
  for (int i = messages - 1; i >= 0; --i) {
    CdrWriter message;
    message.write_string("hello " + std::to_string(i));
    sqlite3_bind_int64(insert, 1, 1000 + i);
    sqlite3_bind_blob(insert, 2, message.bytes().data(), static_cast<int>(message.bytes().size()),
                      SQLITE_TRANSIENT);
    ASSERT_EQ(sqlite3_step(insert), SQLITE_DONE);
    sqlite3_reset(insert);
  }
  sqlite3_finalize(insert);
  sqlite3_close(db);
}

TEST(Bag, ReadsAFolderAnMcapFileAndAnSqliteFile) {
  const fs::path dir = temp_dir("bags");
  const fs::path folder = dir / "recording";
  fs::create_directories(folder);
  write_sample(folder / "recording_0.mcap", McapCompression::kZstd);
  write_bytes(folder / "metadata.yaml", metadata_yaml("mcap", {"recording_0.mcap"}));
  BagReader bag(folder);
  EXPECT_EQ(bag.storage(), "mcap");
  ASSERT_EQ(bag.topics().size(), 1u);  // metadata.yaml's, before reading
  EXPECT_EQ(bag.topics()[0].message_count, 100u);
  std::map<std::string, int> seen;
  std::uint64_t last_ns = 0;
  bag.read([&](const BagTopic& topic, const BagMessage& message) {
    ++seen[topic.name];
    EXPECT_GE(message.log_time_ns, last_ns);
    last_ns = message.log_time_ns;
    if (topic.name == "/a") {
      EXPECT_EQ(topic.type, "std_msgs/msg/String");
      EXPECT_EQ(topic.definition, "string data\n");
      EXPECT_EQ(topic.offered_qos_profiles, "- history: 1");  // metadata.yaml's, kept
      const Value value = MessageDefinition(topic.type, topic.definition).decode(message.data);
      const std::string& data = value.string("data");
      EXPECT_EQ(data.find_first_not_of(data.empty() ? ' ' : data[0]), std::string::npos);
    }
    expect_contains(message.where(), "recording_0.mcap: byte ");
  });
  EXPECT_EQ(seen, (std::map<std::string, int>{{"/a", 100}, {"/b", 100}, {"/raw", 100}}));
  EXPECT_EQ(bag.topics().size(), 3u);

  // The same file named alone.
  BagReader alone(folder / "recording_0.mcap");
  int count = 0;
  alone.read([&](const BagTopic&, const BagMessage&) { ++count; });
  EXPECT_EQ(count, 300);

  const fs::path db3 = dir / "humble.db3";
  write_sqlite_bag(db3, 25);
  BagReader sqlite(db3);
  EXPECT_EQ(sqlite.storage(), "sqlite3");
  ASSERT_EQ(sqlite.topics().size(), 1u);
  EXPECT_EQ(sqlite.topics()[0].offered_qos_profiles, "- depth: 10");
  EXPECT_TRUE(sqlite.topics()[0].definition.empty());  // Humble's carry none: locsim's own serve
  int i = 0;
  sqlite.read([&](const BagTopic& topic, const BagMessage& message) {
    const Value value = MessageDefinition::known(topic.type).decode(message.data);
    EXPECT_EQ(value.string("data"), "hello " + std::to_string(i));
    EXPECT_EQ(message.log_time_ns, 1000u + static_cast<unsigned>(i));
    EXPECT_EQ(message.where(), db3.string() + ": row " + std::to_string(25 - i));
    ++i;
  });
  EXPECT_EQ(i, 25);
}

TEST(Bag, ReadsNothingOutsideItself) {
  const fs::path dir = temp_dir("outside");
  const fs::path secret = dir / "secret.mcap";
  write_sample(secret, McapCompression::kNone);
  const fs::path folder = dir / "bag";
  fs::create_directories(folder);
  const auto refused = [&](const std::string& path) -> std::string {
    write_bytes(folder / "metadata.yaml", metadata_yaml("mcap", {path}));
    try {
      BagReader bag(folder);
      bag.read([](const BagTopic&, const BagMessage&) {});
    } catch (const InputError& e) {
      return e.what();
    }
    return "(read)";
  };
  std::string error = refused("../secret.mcap");
  expect_contains(error, (folder / "metadata.yaml").string() + ":5:7:");
  expect_contains(error, "'../secret.mcap' leaves the bag's folder");
  expect_contains(refused(secret.string()), "is not a path relative to the bag's folder");
  fs::create_symlink(secret, folder / "link.mcap");
  expect_contains(refused("link.mcap"), "resolves outside the bag's folder");
  fs::create_directory_symlink(dir, folder / "up");
  expect_contains(refused("up/secret.mcap"), "resolves outside the bag's folder");
  expect_contains(refused("missing.mcap"), "no such file in the bag's folder");

  // An SQLite file whose messages are a view, not a table, is not a bag.
  const fs::path db3 = dir / "view.db3";
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(db3.c_str(), &db), SQLITE_OK);
  sqlite3_exec(
      db,
      "CREATE TABLE topics(id INTEGER, name TEXT, type TEXT, serialization_format TEXT);"
      "CREATE VIEW messages AS SELECT 1 AS id, 1 AS topic_id, 0 AS timestamp, x'00' AS data;",
      nullptr, nullptr, nullptr);
  sqlite3_close(db);
  try {
    BagReader bag(db3);
    FAIL() << "a view was read as a table";
  } catch (const InputError& e) {
    expect_contains(e.what(), "without a 'messages' table is not a rosbag2 bag");
  }
  // A ROS 1 bag and a text file are named for what they are.
  write_bytes(dir / "old.bag", "#ROSBAG V2.0\n");
  try {
    BagReader bag(dir / "old.bag");
    FAIL();
  } catch (const InputError& e) {
    expect_contains(e.what(), "a ROS 1 bag; locsim reads ROS 2 bags");
  }
}

/// Reads every message of `file` as an import would: each decoded by the bag's definition or
/// locsim's. Returns how it ended: "read", or the kind of error a bad input may raise.
std::string read_everything(const fs::path& file) {
  try {
    BagReader bag(file);
    std::map<std::string, std::shared_ptr<MessageDefinition>> definitions;
    bag.read([&](const BagTopic& topic, const BagMessage& message) {
      try {
        auto& definition = definitions[topic.name];
        if (!definition) {
          definition = std::make_shared<MessageDefinition>(
              topic.definition_encoding == "ros2msg"
                  ? MessageDefinition(topic.type, topic.definition)
                  : MessageDefinition::known(topic.type));
        }
        definition->decode(message.data);
      } catch (const CdrError&) {
      } catch (const DefinitionError&) {
      }
    });
  } catch (const InputError&) {
    return "refused";
  }
  return "read";
}

// A bag from someone else may be anything: every byte flipped, a length cut or grown, and the
// reader refuses or reads it, and never crashes, allocates without bound or reads past the file
// (the sanitizer build runs this too).
TEST(Bag, AMutatedBagIsRefusedOrReadNeverCrashes) {
  const fs::path dir = temp_dir("mutated");
  std::map<std::string, std::size_t> outcomes;
  std::uint64_t state = 0x9e3779b97f4a7c15ull;
  const auto next = [&] {  // splitmix64: the same mutations on every machine
    std::uint64_t z = (state += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  };
  // Without CRCs (a writer may leave them out) the flipped bytes reach the records and messages.
  for (const auto& [compression, crcs] :
       {std::pair{McapCompression::kNone, true}, std::pair{McapCompression::kZstd, true},
        std::pair{McapCompression::kNone, false}, std::pair{McapCompression::kLz4, false}}) {
    const fs::path good = dir / "good.mcap";
    write_sample(good, compression, crcs);
    const std::string bytes = read_file(good);
    for (int i = 0; i < 1000; ++i) {
      std::string mutated = bytes;
      const int edits = 1 + static_cast<int>(next() % 4);
      for (int e = 0; e < edits; ++e) {
        const std::size_t at = next() % mutated.size();
        switch (next() % 3) {
          case 0:  // a random byte
            mutated[at] = static_cast<char>(next());
            break;
          case 1:  // a length's high byte
            mutated[at] = static_cast<char>(0xff);
            break;
          default:  // cut short
            mutated.resize(at);
            break;
        }
        if (mutated.empty()) break;
      }
      write_bytes(dir / "mutated.mcap", mutated);
      ++outcomes[read_everything(dir / "mutated.mcap")];
    }
  }
  // Both outcomes occur: the mutations reach past the checks as well as into them.
  EXPECT_GT(outcomes["refused"], 1000u);  // 3379 of 4000 when written
  EXPECT_GT(outcomes["read"], 200u);      // 621
}

// ---- the independent checkers -------------------------------------------------------------------

/// `node tests/checkers/SCRIPT ARGUMENTS`: the checkers tools/setup installs.
Outcome checker(const std::string& script, const std::string& arguments) {
  const fs::path checkers = fs::path(LOCSIM_SOURCE_DIR) / "tests" / "checkers";
  if (!fs::exists(checkers / "node_modules")) {
    ADD_FAILURE() << "the MCAP checkers are not installed: run tools/setup (it runs npm ci in "
                  << checkers.string() << ")";
    return {};
  }
  return run_command("node " + (checkers / script).string() + " " + arguments);
}

std::vector<json> json_lines(const std::string& text) {
  std::vector<json> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (!line.empty()) lines.push_back(json::parse(line));
  }
  return lines;
}

TEST(BagCheckers, WeReadWhatAnIndependentWriterWritesAndItReadsWhatWeWrite) {
  const fs::path dir = temp_dir("checkers");
  for (const std::string compression : {"zstd", "lz4", "none"}) {
    SCOPED_TRACE(compression);
    // Theirs: written by @mcap/core with messages encoded by @foxglove/rosmsg2-serialization.
    const fs::path theirs = dir / ("theirs_" + compression + ".mcap");
    const Outcome written =
        checker("mcap_write.mjs", theirs.string() + " --compression " + compression);
    ASSERT_EQ(written.exit_code, 0) << written.output;
    const std::vector<json> expected = json_lines(written.output);
    ASSERT_GT(expected.size(), 10u);

    // We read and decode every message of it to the same values, bit for bit.
    std::size_t at = 1;
    McapReader reader(theirs);
    EXPECT_EQ(reader.profile(), "ros2");
    std::vector<McapSchema> schemas;
    std::vector<std::pair<McapChannel, std::vector<Written>>> channels;
    reader.read([&](const McapChannel& channel, const McapSchema* schema, const McapMessage& m) {
      ASSERT_LT(at, expected.size());
      ASSERT_NE(schema, nullptr);
      const json& line = expected[at++];
      EXPECT_EQ(channel.topic, line.at("topic").get<std::string>());
      EXPECT_EQ(schema->name, line.at("schema").get<std::string>());
      EXPECT_EQ(std::to_string(m.log_time_ns), line.at("log_time").get<std::string>());
      EXPECT_EQ(std::to_string(m.publish_time_ns), line.at("publish_time").get<std::string>());
      const MessageDefinition definition(schema->name, schema->data);
      expect_same(definition.decode(m.data), line.at("message"), channel.topic);
      // Re-encoded from their JSON by the definition, the bytes are theirs.
      EXPECT_EQ(definition.encode(line.at("message")), std::string(m.data)) << channel.topic;
    });
    EXPECT_EQ(at, expected.size());

    // Ours: the same messages written by McapWriter; their reader decodes them to the same JSON.
    const fs::path ours = dir / ("ours_" + compression + ".mcap");
    {
      McapWriterOptions options;
      options.compression = compression == "zstd"  ? McapCompression::kZstd
                            : compression == "lz4" ? McapCompression::kLz4
                                                   : McapCompression::kNone;
      options.chunk_bytes = 2000;  // several chunks
      McapWriter writer(ours, options);
      std::map<std::uint16_t, std::uint16_t> schema_ids;
      for (const auto& [id, schema] : reader.schemas()) {
        schema_ids[id] = writer.add_schema(schema.name, schema.encoding, schema.data);
      }
      std::map<std::uint16_t, std::uint16_t> channel_ids;
      for (const auto& [id, channel] : reader.channels()) {
        channel_ids[id] = writer.add_channel(schema_ids.at(channel.schema_id), channel.topic,
                                             channel.message_encoding, channel.metadata);
      }
      McapReader again(theirs);
      again.read([&](const McapChannel& channel, const McapSchema*, const McapMessage& m) {
        writer.write(channel_ids.at(channel.id), m.sequence, m.log_time_ns, m.publish_time_ns,
                     m.data);
      });
      writer.finish();
    }
    for (const std::string mode : {"", "--stream "}) {
      const Outcome dumped = checker("mcap_dump.mjs", mode + ours.string());
      ASSERT_EQ(dumped.exit_code, 0) << dumped.output;
      const std::vector<json> lines = json_lines(dumped.output);
      ASSERT_EQ(lines.size(), expected.size());
      EXPECT_EQ(lines[0].at("channels"), expected[0].at("channels"));
      EXPECT_EQ(lines[0].at("statistics").at("message_count"),
                expected[0].at("statistics").at("message_count"));
      EXPECT_EQ(lines[0].at("header").at("library"), "locsim");
      for (std::size_t i = 1; i < lines.size(); ++i) EXPECT_EQ(lines[i], expected[i]) << i;
    }
  }
}

}  // namespace
}  // namespace locsim::rosbag
