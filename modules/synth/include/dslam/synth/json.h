#pragma once
/** \file json.h
 *  Minimal JSON reader for the label files written by `dslam synth`
 *  (boxes/, panoptic.json, objects.json). Objects keep their key order. */
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace dslam::synth::json {

class Value {
 public:
  enum class Type { Null, Bool, Number, String, Array, Object };
  Type type = Type::Null;
  bool b = false;
  double num = 0;
  std::string str;
  std::vector<Value> arr;
  std::vector<std::pair<std::string, Value>> obj;

  bool isNull() const { return type == Type::Null; }
  bool isObject() const { return type == Type::Object; }
  bool isArray() const { return type == Type::Array; }
  /** Member by key; throws DataError if missing or not an object. */
  const Value& operator[](const std::string& key) const;
  const Value& operator[](size_t i) const;
  bool has(const std::string& key) const;
  size_t size() const { return type == Type::Array ? arr.size() : obj.size(); }
  double number() const;
  int integer() const { return static_cast<int>(number()); }
  const std::string& string() const;
};

/** Parses JSON text; throws DataError with the offset on a syntax error. */
Value parse(const std::string& text, const std::string& what = "<json>");
Value parseFile(const std::string& path);
/** JSON string literal of s (quoted, escaped). */
std::string quote(const std::string& s);

}  // namespace dslam::synth::json
