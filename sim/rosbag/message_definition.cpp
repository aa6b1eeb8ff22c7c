#include "sim/rosbag/message_definition.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "sim/rosbag/cdr.hpp"
#include "sim/rosbag/ros_types.hpp"

namespace locsim::rosbag {
namespace {

/// Nesting deeper than this is refused: a type may hold a sequence of itself, and a message may
/// nest as deep as its bytes allow, but no real message nests 100 deep.
constexpr int kMaxDepth = 100;
/// The longest fixed array a definition may declare: a bigger one is a corrupt schema.
constexpr std::size_t kMaxFixedLength = std::size_t{1} << 24;

struct Primitive {
  std::string_view name;
  FieldType type;
};
constexpr Primitive kPrimitives[] = {
    {"bool", FieldType::kBool},       {"byte", FieldType::kByte},
    {"char", FieldType::kChar},       {"int8", FieldType::kInt8},
    {"uint8", FieldType::kUint8},     {"int16", FieldType::kInt16},
    {"uint16", FieldType::kUint16},   {"int32", FieldType::kInt32},
    {"uint32", FieldType::kUint32},   {"int64", FieldType::kInt64},
    {"uint64", FieldType::kUint64},   {"float32", FieldType::kFloat32},
    {"float64", FieldType::kFloat64}, {"string", FieldType::kString},
    {"wstring", FieldType::kWString},
};

std::string_view trim(std::string_view text) {
  const std::size_t begin = text.find_first_not_of(" \t\r");
  if (begin == std::string_view::npos) return {};
  return text.substr(begin, text.find_last_not_of(" \t\r") - begin + 1);
}

/// The line without its comment: a '#' outside quotes (a default string may hold one).
std::string_view strip_comment(std::string_view line) {
  char quote = 0;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quote != 0) {
      if (c == '\\') {
        ++i;
      } else if (c == quote) {
        quote = 0;
      }
    } else if (c == '"' || c == '\'') {
      quote = c;
    } else if (c == '#') {
      return line.substr(0, i);
    }
  }
  return line;
}

bool is_name_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
}

std::size_t parse_length(std::string_view digits, const std::string& where) {
  std::size_t value = 0;
  const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (digits.empty() || error != std::errc() || end != digits.data() + digits.size()) {
    throw DefinitionError(where + ": '" + std::string(digits) + "' is not an array length");
  }
  if (value > kMaxFixedLength) {
    throw DefinitionError(where + ": an array of " + std::string(digits) +
                          " elements is longer than locsim reads (" +
                          std::to_string(kMaxFixedLength) + ")");
  }
  return value;
}

/// "pkg/Type" for a field's type as written in `package`'s definition.
std::string resolve_type_name(std::string_view written, std::string_view package) {
  if (written == "Header") return "std_msgs/Header";
  if (written.find('/') == std::string_view::npos) {
    return std::string(package) + "/" + std::string(written);
  }
  return short_type_name(written);
}

FieldDefinition parse_field(std::string_view type_token, std::string_view name,
                            std::string_view package, const std::string& where) {
  FieldDefinition field;
  field.name = std::string(name);
  std::string_view base = type_token;
  if (const std::size_t open = type_token.find('['); open != std::string_view::npos) {
    if (type_token.back() != ']') {
      throw DefinitionError(where + ": '" + std::string(type_token) + "' has no closing ']'");
    }
    base = type_token.substr(0, open);
    const std::string_view inside = type_token.substr(open + 1, type_token.size() - open - 2);
    if (inside.empty()) {
      field.shape = FieldDefinition::Shape::kSequence;
    } else if (inside.starts_with("<=")) {
      field.shape = FieldDefinition::Shape::kSequence;
      field.length = parse_length(inside.substr(2), where);
    } else {
      field.shape = FieldDefinition::Shape::kFixedArray;
      field.length = parse_length(inside, where);
    }
  }
  // Bounded strings: string<=10, wstring<=10 (the bound is the writer's business).
  if (const std::size_t bound = base.find("<="); bound != std::string_view::npos) {
    base = base.substr(0, bound);
  }
  if (base.empty()) throw DefinitionError(where + ": a field without a type");
  const auto* primitive = std::find_if(std::begin(kPrimitives), std::end(kPrimitives),
                                       [&](const Primitive& p) { return p.name == base; });
  if (primitive != std::end(kPrimitives)) {
    field.type = primitive->type;
  } else {
    field.type = FieldType::kMessage;
    field.message_type = resolve_type_name(base, package);
  }
  return field;
}

/// One type's text parsed into fields; constants and defaults skipped.
TypeDefinition parse_type(std::string name, std::string_view text, int first_line,
                          const std::string& schema) {
  TypeDefinition type;
  type.name = std::move(name);
  const std::string package = type.name.substr(0, type.name.find('/'));
  int line_number = first_line;
  std::size_t begin = 0;
  while (begin <= text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = trim(strip_comment(text.substr(begin, end - begin)));
    begin = end + 1;
    const std::string where = schema + " line " + std::to_string(line_number++);
    if (line.empty()) continue;
    const std::size_t space = line.find_first_of(" \t");
    if (space == std::string_view::npos) {
      throw DefinitionError(where + ": '" + std::string(line) + "' is a type without a name");
    }
    const std::string_view type_token = line.substr(0, space);
    const std::string_view rest = trim(line.substr(space));
    std::size_t name_end = 0;
    while (name_end < rest.size() && is_name_char(rest[name_end])) ++name_end;
    if (name_end == 0) {
      throw DefinitionError(where + ": '" + std::string(line) + "' has no field name");
    }
    // NAME=value (or NAME = value) is a constant: it takes no bytes in a message.
    if (trim(rest.substr(name_end)).starts_with('=')) continue;
    type.fields.push_back(parse_field(type_token, rest.substr(0, name_end), package, where));
  }
  return type;
}

bool is_separator(std::string_view line) {
  line = trim(line);
  return line.size() >= 3 && line.find_first_not_of('=') == std::string_view::npos;
}

}  // namespace

std::string short_type_name(std::string_view type_name) {
  const std::size_t slash = type_name.find('/');
  if (slash != std::string_view::npos && type_name.substr(slash).starts_with("/msg/")) {
    return std::string(type_name.substr(0, slash)) + std::string(type_name.substr(slash + 4));
  }
  return std::string(type_name);
}

MessageDefinition::MessageDefinition(std::string_view type_name, std::string_view text) {
  const std::string root = short_type_name(type_name);
  const std::string schema = "the definition of " + std::string(type_name);
  if (root.find('/') == std::string::npos) {
    throw DefinitionError(schema + ": the type name is not pkg/Type or pkg/msg/Type");
  }
  // Sections: the root's text, then "=====" / "MSG: pkg/Type" / text, for each type it uses.
  std::map<std::string, TypeDefinition, std::less<>> carried;
  std::string section_name = root;
  std::size_t section_begin = 0;
  int section_line = 1;
  int line_number = 1;
  std::size_t begin = 0;
  const auto close_section = [&](std::size_t end) {
    TypeDefinition type = parse_type(section_name, text.substr(section_begin, end - section_begin),
                                     section_line, schema);
    carried.emplace(type.name, std::move(type));
  };
  while (begin < text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = text.substr(begin, end - begin);
    if (is_separator(line)) {
      close_section(begin);
      // The next non-empty line names the section's type.
      std::size_t next = end + 1;
      int next_line = line_number + 1;
      std::string_view header;
      while (next < text.size()) {
        std::size_t next_end = text.find('\n', next);
        if (next_end == std::string_view::npos) next_end = text.size();
        header = trim(text.substr(next, next_end - next));
        next = next_end + 1;
        ++next_line;
        if (!header.empty()) break;
      }
      if (!header.starts_with("MSG:")) {
        throw DefinitionError(schema + " line " + std::to_string(line_number) +
                              ": a separator not followed by 'MSG: pkg/Type'");
      }
      section_name = short_type_name(trim(header.substr(4)));
      section_begin = std::min(next, text.size());
      section_line = next_line;
      line_number = next_line;
      begin = next;
      continue;
    }
    begin = end + 1;
    ++line_number;
  }
  close_section(text.size());

  // The root first, then the types it uses depth first, each once; a type the text does not
  // carry comes from locsim's own definitions.
  std::vector<TypeDefinition> types;
  std::map<std::string, std::size_t, std::less<>> index;
  std::vector<std::string> on_path;  // for cycles through fields that always hold the type
  std::function<std::size_t(const std::string&, const std::string&)> add =
      [&](const std::string& name, const std::string& used_by) -> std::size_t {
    if (const auto found = index.find(name); found != index.end()) return found->second;
    TypeDefinition type;
    if (const auto found = carried.find(name); found != carried.end()) {
      type = found->second;
    } else if (const std::string_view known = known_definition(name); !known.empty()) {
      type = parse_type(name, known, 1, "locsim's definition of " + name);
    } else {
      throw DefinitionError(schema + ": " + used_by + " uses " + name +
                            ", which neither the bag defines nor locsim knows");
    }
    const std::size_t at = types.size();
    index.emplace(name, at);
    types.push_back(type);
    on_path.push_back(name);
    for (std::size_t f = 0; f < type.fields.size(); ++f) {
      FieldDefinition& field = type.fields[f];
      if (field.type != FieldType::kMessage) continue;
      const bool always_held = field.shape != FieldDefinition::Shape::kSequence;
      if (always_held &&
          std::find(on_path.begin(), on_path.end(), field.message_type) != on_path.end()) {
        throw DefinitionError(schema + ": " + name + "." + field.name + " holds " +
                              field.message_type + " inside itself");
      }
      field.message_index = add(field.message_type, name);
      types[at].fields[f].message_index = field.message_index;
    }
    on_path.pop_back();
    return at;
  };
  add(root, "it");
  types_ = std::make_shared<const std::vector<TypeDefinition>>(std::move(types));
}

MessageDefinition MessageDefinition::known(std::string_view type_name) {
  const std::string_view text = known_definition(type_name);
  if (text.empty()) {
    throw DefinitionError("locsim does not know the type " + std::string(type_name));
  }
  return MessageDefinition(type_name, text);
}

Value MessageDefinition::decode(std::string_view cdr) const {
  CdrReader in(cdr);
  Value root;
  decode_message(in, 0, 0, root);
  return root;
}

void MessageDefinition::decode_message(CdrReader& in, std::size_t type, int depth,
                                       Value& out) const {
  if (depth > kMaxDepth) {
    throw CdrError("byte " + std::to_string(in.offset()) + ": messages nested deeper than " +
                   std::to_string(kMaxDepth));
  }
  const TypeDefinition& definition = (*types_)[type];
  out.kind_ = Value::Kind::kMessage;
  out.type_ = std::shared_ptr<const TypeDefinition>(types_, &definition);
  if (definition.fields.empty()) {
    in.read<std::uint8_t>();  // rosidl's placeholder member of an empty message
    return;
  }
  out.items_.resize(definition.fields.size());
  for (std::size_t f = 0; f < definition.fields.size(); ++f) {
    decode_field(in, definition.fields[f], depth, out.items_[f]);
  }
}

namespace {

std::size_t wire_size(FieldType type) {
  switch (type) {
    case FieldType::kBool:
    case FieldType::kByte:
    case FieldType::kChar:
    case FieldType::kInt8:
    case FieldType::kUint8:
      return 1;
    case FieldType::kInt16:
    case FieldType::kUint16:
      return 2;
    case FieldType::kInt32:
    case FieldType::kUint32:
    case FieldType::kFloat32:
    case FieldType::kString:  // at least its length
    case FieldType::kWString:
      return 4;
    case FieldType::kInt64:
    case FieldType::kUint64:
    case FieldType::kFloat64:
      return 8;
    case FieldType::kMessage:
      return 1;  // at least a placeholder byte
  }
  return 1;
}

void read_numbers(CdrReader& in, FieldType type, std::size_t count, double* out) {
  switch (type) {
    case FieldType::kBool:
    case FieldType::kByte:
    case FieldType::kChar:
    case FieldType::kUint8:
      return in.read_numbers<std::uint8_t>(count, out);
    case FieldType::kInt8:
      return in.read_numbers<std::int8_t>(count, out);
    case FieldType::kInt16:
      return in.read_numbers<std::int16_t>(count, out);
    case FieldType::kUint16:
      return in.read_numbers<std::uint16_t>(count, out);
    case FieldType::kInt32:
      return in.read_numbers<std::int32_t>(count, out);
    case FieldType::kUint32:
      return in.read_numbers<std::uint32_t>(count, out);
    case FieldType::kInt64:
      return in.read_numbers<std::int64_t>(count, out);
    case FieldType::kUint64:
      return in.read_numbers<std::uint64_t>(count, out);
    case FieldType::kFloat32:
      return in.read_numbers<float>(count, out);
    case FieldType::kFloat64:
      return in.read_numbers<double>(count, out);
    case FieldType::kString:
    case FieldType::kWString:
    case FieldType::kMessage:
      break;
  }
  throw std::logic_error("read_numbers of a type that is not a number");
}

}  // namespace

void MessageDefinition::decode_field(CdrReader& in, const FieldDefinition& field, int depth,
                                     Value& out) const {
  if (field.type == FieldType::kWString) {
    // rmw implementations disagree on a wide character's width (2 or 4 bytes); no message locsim
    // reads has one, so a topic with one is skipped rather than read wrongly.
    throw CdrError("byte " + std::to_string(in.offset()) + ": field '" + field.name +
                   "' is a wstring, which locsim does not read");
  }
  std::size_t count = 1;
  if (field.shape == FieldDefinition::Shape::kFixedArray) {
    count = field.length;
    // Checked before anything is made for it: a corrupt schema's array of 16 M messages must not
    // allocate gigabytes for a message of a few bytes.
    if (count > in.remaining() / wire_size(field.type)) {
      throw CdrError("byte " + std::to_string(in.offset()) + ": field '" + field.name + "' of " +
                     std::to_string(count) + " elements runs past the message's end");
    }
  } else if (field.shape == FieldDefinition::Shape::kSequence) {
    count = in.read_count(wire_size(field.type));
  }
  if (field.type == FieldType::kString) {
    const auto read_one = [&](Value& v) {
      v.kind_ = Value::Kind::kString;
      v.string_ = in.read_string();
    };
    if (field.shape == FieldDefinition::Shape::kSingle) return read_one(out);
    out.kind_ = Value::Kind::kList;
    out.items_.resize(count);
    for (Value& item : out.items_) read_one(item);
    return;
  }
  if (field.type == FieldType::kMessage) {
    if (field.shape == FieldDefinition::Shape::kSingle) {
      return decode_message(in, field.message_index, depth + 1, out);
    }
    out.kind_ = Value::Kind::kList;
    out.items_.resize(count);
    for (Value& item : out.items_) decode_message(in, field.message_index, depth + 1, item);
    return;
  }
  if (field.shape == FieldDefinition::Shape::kSingle) {
    out.kind_ = Value::Kind::kNumber;
    read_numbers(in, field.type, 1, &out.number_);
    return;
  }
  out.kind_ = Value::Kind::kNumbers;
  out.numbers_.resize(count);
  read_numbers(in, field.type, count, out.numbers_.data());
}

// Encoding.

namespace {

double json_double(const nlohmann::json& value, const std::string& path) {
  if (value.is_boolean()) return value.get<bool>() ? 1.0 : 0.0;
  if (value.is_number()) return value.get<double>();
  if (value.is_string()) {
    const std::string text = value.get<std::string>();
    char* end = nullptr;
    const double parsed = std::strtod(text.c_str(), &end);  // NaN, Infinity, -0, decimals
    if (!text.empty() && end == text.c_str() + text.size()) return parsed;
  }
  throw std::invalid_argument(path + ": " + value.dump() + " is not a number");
}

template <typename T>
T json_integer(const nlohmann::json& value, const std::string& path) {
  if (value.is_string()) {
    const std::string text = value.get<std::string>();
    T parsed{};
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), parsed);
    if (error == std::errc() && end == text.data() + text.size()) return parsed;
  } else if (value.is_boolean()) {
    return static_cast<T>(value.get<bool>() ? 1 : 0);
  } else if (value.is_number_integer()) {
    return value.get<T>();
  } else if (value.is_number_float()) {
    const double d = value.get<double>();
    if (d == std::floor(d)) return static_cast<T>(d);
  }
  throw std::invalid_argument(path + ": " + value.dump() + " is not an integer");
}

void encode_number(FieldType type, const nlohmann::json& value, const std::string& path,
                   CdrWriter& out) {
  switch (type) {
    case FieldType::kBool:
    case FieldType::kByte:
    case FieldType::kChar:
    case FieldType::kUint8:
      return out.write(json_integer<std::uint8_t>(value, path));
    case FieldType::kInt8:
      return out.write(json_integer<std::int8_t>(value, path));
    case FieldType::kInt16:
      return out.write(json_integer<std::int16_t>(value, path));
    case FieldType::kUint16:
      return out.write(json_integer<std::uint16_t>(value, path));
    case FieldType::kInt32:
      return out.write(json_integer<std::int32_t>(value, path));
    case FieldType::kUint32:
      return out.write(json_integer<std::uint32_t>(value, path));
    case FieldType::kInt64:
      return out.write(json_integer<std::int64_t>(value, path));
    case FieldType::kUint64:
      return out.write(json_integer<std::uint64_t>(value, path));
    case FieldType::kFloat32:
      return out.write(static_cast<float>(json_double(value, path)));
    case FieldType::kFloat64:
      return out.write(json_double(value, path));
    case FieldType::kString:
    case FieldType::kWString:
    case FieldType::kMessage:
      break;
  }
  throw std::logic_error("encode_number of a type that is not a number");
}

}  // namespace

std::string MessageDefinition::encode(const nlohmann::json& message) const {
  CdrWriter out;
  encode_message(0, message, name(), out);
  return out.bytes();
}

void MessageDefinition::encode_message(std::size_t type, const nlohmann::json& message,
                                       const std::string& path, CdrWriter& out) const {
  const TypeDefinition& definition = (*types_)[type];
  if (!message.is_object()) throw std::invalid_argument(path + ": not an object");
  if (definition.fields.empty()) return out.write(std::uint8_t{0});
  for (const FieldDefinition& field : definition.fields) {
    const std::string at = path + "." + field.name;
    const auto found = message.find(field.name);
    if (found == message.end()) throw std::invalid_argument(at + ": missing");
    const auto one = [&](const nlohmann::json& value, const std::string& where) {
      if (field.type == FieldType::kMessage) {
        encode_message(field.message_index, value, where, out);
      } else if (field.type == FieldType::kString) {
        if (!value.is_string()) throw std::invalid_argument(where + ": not a string");
        out.write_string(value.get<std::string>());
      } else if (field.type == FieldType::kWString) {
        throw std::invalid_argument(where + ": wstring is not written");
      } else {
        encode_number(field.type, value, where, out);
      }
    };
    if (field.shape == FieldDefinition::Shape::kSingle) {
      one(*found, at);
      continue;
    }
    if (!found->is_array()) throw std::invalid_argument(at + ": not an array");
    if (field.shape == FieldDefinition::Shape::kFixedArray && found->size() != field.length) {
      throw std::invalid_argument(at + ": " + std::to_string(found->size()) + " elements, not " +
                                  std::to_string(field.length));
    }
    if (field.shape == FieldDefinition::Shape::kSequence) {
      if (field.length > 0 && found->size() > field.length) {
        throw std::invalid_argument(at + ": " + std::to_string(found->size()) +
                                    " elements, more than its bound " +
                                    std::to_string(field.length));
      }
      out.write_count(found->size());
    }
    for (std::size_t i = 0; i < found->size(); ++i) {
      one((*found)[i], at + "[" + std::to_string(i) + "]");
    }
  }
}

// Value's accessors.

namespace {
[[noreturn]] void wrong_kind(const char* wanted) {
  throw std::out_of_range(std::string("the value is not ") + wanted);
}
}  // namespace

double Value::number() const {
  if (kind_ != Kind::kNumber) wrong_kind("a number");
  return number_;
}
const std::string& Value::string() const {
  if (kind_ != Kind::kString) wrong_kind("a string");
  return string_;
}
const std::vector<double>& Value::numbers() const {
  if (kind_ != Kind::kNumbers) wrong_kind("an array of numbers");
  return numbers_;
}
const std::vector<Value>& Value::items() const {
  if (kind_ != Kind::kList && kind_ != Kind::kMessage) wrong_kind("a list or a message");
  return items_;
}

const Value* Value::find(std::string_view path) const {
  const Value* at = this;
  while (!path.empty()) {
    if (at->kind_ != Kind::kMessage || at->type_ == nullptr) return nullptr;
    const std::size_t dot = path.find('.');
    const std::string_view name = path.substr(0, dot);
    const auto& fields = at->type_->fields;
    const auto field = std::find_if(fields.begin(), fields.end(),
                                    [&](const FieldDefinition& f) { return f.name == name; });
    if (field == fields.end() || at->items_.empty()) return nullptr;
    at = &at->items_[static_cast<std::size_t>(field - fields.begin())];
    path = dot == std::string_view::npos ? std::string_view() : path.substr(dot + 1);
  }
  return at;
}

const Value& Value::at(std::string_view path) const {
  const Value* found = find(path);
  if (found == nullptr) {
    throw std::out_of_range("the message " +
                            (type_ != nullptr ? type_->name + " " : std::string()) +
                            "has no field " + std::string(path));
  }
  return *found;
}

}  // namespace locsim::rosbag
