// Parsing JSON text with limits: a SAX builder that names the field of every refusal.
#include "distlab/server/json_text.hpp"

#include <optional>
#include <utility>
#include <vector>

#include "distlab/geometry/error.hpp"
#include "distlab/server/json_fields.hpp"

namespace distlab::server {

using json = nlohmann::json;

std::string shorten(const std::string& s, std::size_t max) {
  if (s.size() <= max) return s;
  std::size_t n = max;
  while (n > 0 && (static_cast<unsigned char>(s[n]) & 0xC0) == 0x80) --n;
  return s.substr(0, n) + "...";
}

namespace {

// ---------------------------------------------------------------------------------------------
// Parsing text: a SAX builder, because nlohmann's DOM parser cannot say *where* a number
// overflowed, and a depth limit must stop hostile nesting before anything is built.

class Builder final : public json::json_sax_t {
 public:
  Builder(json& root, bool binary) : root_(root), binary_(binary) {}

  bool null() override { return add(json(nullptr)); }
  bool boolean(bool v) override { return add(json(v)); }
  bool number_integer(number_integer_t v) override { return add(json(v)); }
  bool number_unsigned(number_unsigned_t v) override { return add(json(v)); }
  bool number_float(number_float_t v, const string_t&) override { return add(json(v)); }
  bool string(string_t& v) override { return add(json(std::move(v))); }
  // JSON text has no binary values; msgpack's "bin" values are the frames' arrays. An ext value
  // arrives here too, with its type as the subtype: kept, so that it is not taken for a bin.
  bool binary(binary_t& v) override {
    if (!binary_) return false;
    const bool ext = v.has_subtype();
    const auto type = v.subtype();
    auto& bytes = static_cast<binary_t::container_type&>(v);
    return add(ext ? json::binary(std::move(bytes), type) : json::binary(std::move(bytes)));
  }
  bool start_object(std::size_t) override { return open(json::object()); }
  bool start_array(std::size_t) override { return open(json::array()); }
  bool end_object() override { return close(); }
  bool end_array() override { return close(); }
  bool key(string_t& k) override {
    if (stack_.back().node->contains(k)) {
      invalid_ =
          InvalidInput(json_key_path(stack_.back().path, k), "duplicate key \"" + shorten(k) + "\"");
      return false;
    }
    key_ = std::move(k);
    return true;
  }
  bool parse_error(std::size_t position, const std::string&,
                   const nlohmann::detail::exception& ex) override {
    if (ex.id == 406)  // out_of_range.406: a number that overflows a double, e.g. 1e999
      invalid_ = InvalidInput(next_path(), "number is out of range (not a finite double)");
    else
      syntax_ = JsonSyntaxError(ex.what(), position);
    return false;
  }

  std::optional<InvalidInput> invalid_;
  std::optional<JsonSyntaxError> syntax_;

 private:
  struct Frame {
    json* node;
    std::string path;
  };

  // Path of the value about to be added.
  std::string next_path() const {
    if (stack_.empty()) return "";
    const Frame& f = stack_.back();
    return f.node->is_array() ? json_index_path(f.path, f.node->size()) : json_key_path(f.path, key_);
  }
  json* add(json&& v) {
    if (stack_.empty()) {
      root_ = std::move(v);
      return &root_;
    }
    json& top = *stack_.back().node;
    if (top.is_array()) {
      top.push_back(std::move(v));
      return &top.back();  // parents only grow after this child is closed: pointer stays valid
    }
    json& slot = top[key_];
    slot = std::move(v);
    return &slot;
  }
  bool open(json&& container) {
    if (stack_.size() >= static_cast<std::size_t>(kMaxJsonDepth)) {
      invalid_ =
          InvalidInput("", "JSON nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
      return false;
    }
    std::string path = next_path();
    json* node = add(std::move(container));
    stack_.push_back({node, std::move(path)});
    return true;
  }
  bool close() {
    stack_.pop_back();
    return true;
  }

  json& root_;
  bool binary_;
  std::vector<Frame> stack_;
  std::string key_;
};

}  // namespace

json parse_json_text(std::string_view text, std::size_t max_bytes) {
  if (text.size() > max_bytes)
    throw InvalidInput("", "request too large: " + std::to_string(text.size()) + " bytes, the limit is " +
                               std::to_string(max_bytes) + " (max_body_bytes)");
  json root;
  Builder builder(root, false);
  const bool ok = json::sax_parse(text.begin(), text.end(), &builder);
  if (builder.invalid_) throw *builder.invalid_;
  if (builder.syntax_) throw *builder.syntax_;
  if (!ok) throw JsonSyntaxError("malformed JSON", 0);
  return root;
}

json parse_msgpack(std::string_view bytes) {
  json root;
  Builder builder(root, true);
  const bool ok = json::sax_parse(bytes.begin(), bytes.end(), &builder, json::input_format_t::msgpack);
  if (builder.invalid_) throw *builder.invalid_;
  if (builder.syntax_ || !ok)
    throw InvalidInput("body", "malformed msgpack" + (builder.syntax_ ? std::string(": ") + builder.syntax_->what() : std::string()));
  return root;
}

}  // namespace distlab::server
