#include "dslam/synth/json.h"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "dslam/core/error.h"

namespace dslam::synth::json {

const Value& Value::operator[](const std::string& key) const {
  if (type != Type::Object) throw DataError("json: '" + key + "' looked up in a non-object");
  for (const auto& kv : obj)
    if (kv.first == key) return kv.second;
  throw DataError("json: missing key '" + key + "'");
}

const Value& Value::operator[](size_t i) const {
  if (type != Type::Array || i >= arr.size()) throw DataError("json: index " + std::to_string(i) + " out of range");
  return arr[i];
}

bool Value::has(const std::string& key) const {
  if (type != Type::Object) return false;
  for (const auto& kv : obj)
    if (kv.first == key) return true;
  return false;
}

double Value::number() const {
  if (type == Type::Bool) return b ? 1 : 0;
  if (type != Type::Number) throw DataError("json: value is not a number");
  return num;
}

const std::string& Value::string() const {
  if (type != Type::String) throw DataError("json: value is not a string");
  return str;
}

namespace {

struct Parser {
  const std::string& t;
  const std::string& what;
  size_t i = 0;

  [[noreturn]] void fail(const std::string& msg) {
    throw DataError(what + ": JSON syntax error at offset " + std::to_string(i) + ": " + msg);
  }
  void ws() {
    while (i < t.size() && (t[i] == ' ' || t[i] == '\n' || t[i] == '\r' || t[i] == '\t')) i++;
  }
  bool lit(const char* s) {
    size_t n = 0;
    while (s[n]) n++;
    if (t.compare(i, n, s) == 0) {
      i += n;
      return true;
    }
    return false;
  }
  std::string parseString() {
    if (t[i] != '"') fail("expected '\"'");
    i++;
    std::string s;
    while (i < t.size() && t[i] != '"') {
      char c = t[i++];
      if (c == '\\') {
        if (i >= t.size()) fail("bad escape");
        const char e = t[i++];
        switch (e) {
          case 'n': s += '\n'; break;
          case 't': s += '\t'; break;
          case 'r': s += '\r'; break;
          case 'b': s += '\b'; break;
          case 'f': s += '\f'; break;
          case 'u': {
            if (i + 4 > t.size()) fail("bad \\u escape");
            const unsigned cp = std::strtoul(t.substr(i, 4).c_str(), nullptr, 16);
            i += 4;
            if (cp < 0x80) {
              s += static_cast<char>(cp);
            } else if (cp < 0x800) {
              s += static_cast<char>(0xC0 | (cp >> 6));
              s += static_cast<char>(0x80 | (cp & 0x3F));
            } else {
              s += static_cast<char>(0xE0 | (cp >> 12));
              s += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
              s += static_cast<char>(0x80 | (cp & 0x3F));
            }
            break;
          }
          default: s += e;
        }
      } else {
        s += c;
      }
    }
    if (i >= t.size()) fail("unterminated string");
    i++;
    return s;
  }
  Value parseValue() {
    ws();
    if (i >= t.size()) fail("unexpected end");
    Value v;
    const char c = t[i];
    if (c == '{') {
      v.type = Value::Type::Object;
      i++;
      ws();
      if (i < t.size() && t[i] == '}') {
        i++;
        return v;
      }
      while (true) {
        ws();
        std::string k = parseString();
        ws();
        if (i >= t.size() || t[i] != ':') fail("expected ':'");
        i++;
        v.obj.emplace_back(std::move(k), parseValue());
        ws();
        if (i < t.size() && t[i] == ',') {
          i++;
          continue;
        }
        if (i < t.size() && t[i] == '}') {
          i++;
          break;
        }
        fail("expected ',' or '}'");
      }
    } else if (c == '[') {
      v.type = Value::Type::Array;
      i++;
      ws();
      if (i < t.size() && t[i] == ']') {
        i++;
        return v;
      }
      while (true) {
        v.arr.push_back(parseValue());
        ws();
        if (i < t.size() && t[i] == ',') {
          i++;
          continue;
        }
        if (i < t.size() && t[i] == ']') {
          i++;
          break;
        }
        fail("expected ',' or ']'");
      }
    } else if (c == '"') {
      v.type = Value::Type::String;
      v.str = parseString();
    } else if (lit("true")) {
      v.type = Value::Type::Bool;
      v.b = true;
    } else if (lit("false")) {
      v.type = Value::Type::Bool;
    } else if (lit("null")) {
      v.type = Value::Type::Null;
    } else {
      const char* b = t.c_str() + i;
      char* e = nullptr;
      v.num = std::strtod(b, &e);
      if (e == b) fail(std::string("unexpected character '") + c + "'");
      v.type = Value::Type::Number;
      i += static_cast<size_t>(e - b);
    }
    return v;
  }
};

}  // namespace

Value parse(const std::string& text, const std::string& what) {
  Parser p{text, what};
  Value v = p.parseValue();
  p.ws();
  if (p.i != text.size()) p.fail("trailing characters");
  return v;
}

Value parseFile(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw DataError("cannot read " + path);
  std::stringstream ss;
  ss << f.rdbuf();
  return parse(ss.str(), path);
}

std::string quote(const std::string& s) {
  std::string o = "\"";
  for (unsigned char c : s) {
    if (c == '"' || c == '\\') {
      o += '\\';
      o += static_cast<char>(c);
    } else if (c == '\n') {
      o += "\\n";
    } else if (c < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      o += buf;
    } else {
      o += static_cast<char>(c);
    }
  }
  return o + "\"";
}

}  // namespace dslam::synth::json
