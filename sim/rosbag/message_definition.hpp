// ROS 2 message definitions as a bag carries them, and messages decoded by them.
//
// A "ros2msg" schema is the type's .msg text, then, for each type it uses, a line of '=', a line
// "MSG: pkg/Type" and that type's text (rosbag2 writes MCAP schemas and, since Iron, its SQLite
// bags' message_definitions so). Constants and default values are parsed past, comments dropped.
// A definition names types as pkg/Type, pkg/msg/Type, Type (the same package) or Header
// (std_msgs/Header); a type the text does not carry is looked up in the definitions locsim knows
// (ros_types.hpp): Humble's SQLite bags carry none.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace locsim::rosbag {

/// A definition that cannot be parsed or resolved; the message names the type, line and text.
class DefinitionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class FieldType : std::uint8_t {
  kBool,
  kByte,
  kChar,
  kInt8,
  kUint8,
  kInt16,
  kUint16,
  kInt32,
  kUint32,
  kInt64,
  kUint64,
  kFloat32,
  kFloat64,
  kString,
  kWString,
  kMessage
};

struct FieldDefinition {
  enum class Shape : std::uint8_t { kSingle, kFixedArray, kSequence };
  std::string name;
  FieldType type = FieldType::kInt32;
  std::string message_type;       // "pkg/Type", when type is kMessage
  std::size_t message_index = 0;  // into MessageDefinition::types(), when type is kMessage
  Shape shape = Shape::kSingle;
  std::size_t length = 0;  // a fixed array's length, a bounded sequence's bound (0: unbounded)
};

struct TypeDefinition {
  std::string name;                     // "pkg/Type"
  std::vector<FieldDefinition> fields;  // empty: CDR holds one placeholder byte (as rosidl adds)
};

class MessageDefinition;

/// A decoded message: a tree of messages, lists, strings and numbers. Every number is a double
/// (integers exact to 2^53: enough for times, counts and ids; a uint64 past it is rounded).
/// Arrays of numbers are kept as one vector (a scan's ranges, a map's cells). A message keeps its
/// type (shared with the MessageDefinition): a Value may outlive the definition that decoded it.
class Value {
 public:
  enum class Kind : std::uint8_t { kNumber, kString, kNumbers, kList, kMessage };

  Kind kind() const { return kind_; }
  double number() const;
  const std::string& string() const;
  const std::vector<double>& numbers() const;
  /// A list's elements (strings or messages), or a message's fields in definition order.
  const std::vector<Value>& items() const;
  /// A message's field, by a path of names ("pose.pose.position.x"); nullptr when there is none.
  const Value* find(std::string_view path) const;
  /// As find(), but throws std::out_of_range naming the path when there is none.
  const Value& at(std::string_view path) const;
  /// at(path).number(), and the same for strings and arrays of numbers.
  double number(std::string_view path) const { return at(path).number(); }
  const std::string& string(std::string_view path) const { return at(path).string(); }
  const std::vector<double>& numbers(std::string_view path) const { return at(path).numbers(); }
  /// A message's type, when kind() is kMessage.
  const TypeDefinition* type() const { return type_.get(); }

 private:
  friend class MessageDefinition;
  Kind kind_ = Kind::kNumber;
  double number_ = 0.0;
  std::string string_;
  std::vector<double> numbers_;
  std::vector<Value> items_;
  std::shared_ptr<const TypeDefinition> type_;
};

/// One message type and every type it uses, resolved; decodes CDR messages of it.
class MessageDefinition {
 public:
  /// Parses `text` as the definition of `type_name` ("pkg/msg/Type" or "pkg/Type"). Throws
  /// DefinitionError naming the type and line.
  MessageDefinition(std::string_view type_name, std::string_view text);

  /// The definition of a type locsim knows (ros_types.hpp), without a text from a bag.
  static MessageDefinition known(std::string_view type_name);

  const std::string& name() const { return types_->front().name; }
  /// The type itself first, then every type it uses.
  const std::vector<TypeDefinition>& types() const { return *types_; }

  /// Decodes one message. Throws CdrError (naming the byte) when the bytes do not hold one; bytes
  /// after the message are allowed (padding).
  Value decode(std::string_view cdr) const;

  /// Encodes a message given as JSON: an object per message with every field, arrays for arrays,
  /// numbers (or true/false) for numbers; a number JSON cannot hold as a string ("NaN",
  /// "Infinity", "-Infinity", "-0", a 64-bit integer's decimal digits). Throws
  /// std::invalid_argument naming the field that is missing or of the wrong kind.
  std::string encode(const nlohmann::json& message) const;

 private:
  void decode_message(class CdrReader& in, std::size_t type, int depth, Value& out) const;
  void decode_field(CdrReader& in, const FieldDefinition& field, int depth, Value& out) const;
  void encode_message(std::size_t type, const nlohmann::json& message, const std::string& path,
                      class CdrWriter& out) const;
  std::shared_ptr<const std::vector<TypeDefinition>> types_;
};

/// "pkg/msg/Type" and "pkg/Type" both as "pkg/Type".
std::string short_type_name(std::string_view type_name);

}  // namespace locsim::rosbag
