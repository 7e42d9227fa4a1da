// COLLADA checks made before assimp parses a file: the document's unit, and the malformations
// that make assimp 5.2 hang or crash instead of reporting an error (found by mutation fuzzing):
//   - an index list <p> or <h> holding anything but integers: assimp loops forever;
//   - a <float_array> (or other *_array) whose count attribute is missing or not a number:
//     assimp dereferences a null pointer;
//   - <instance_node> references that form a cycle: assimp recurses until the stack overflows.
// A small tag scanner (comments, CDATA, processing instructions and DOCTYPE skipped) is enough
// for these; everything else is left to assimp, which reports it.
#include <pairgrasp/error.hpp>

#include "mesh_internal.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <locale>
#include <sstream>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

namespace pairgrasp::detail {

namespace {

struct Tag {
  std::string name;
  bool closing = false;       // </name>
  bool self_closing = false;  // <name ... />
  std::size_t begin = 0;      // offset of '<'
  std::size_t end = 0;        // offset just past '>'
  std::vector<std::pair<std::string, std::string>> attributes;

  const std::string* attribute(const std::string& key) const {
    for (const auto& [k, v] : attributes)
      if (k == key) return &v;
    return nullptr;
  }
};

class TagScanner {
 public:
  TagScanner(const std::string& path, const std::string& text) : path_(path), text_(text) {}

  // The next start or end tag; false at the end of the text.
  bool next(Tag& tag) {
    while (true) {
      const std::size_t lt = text_.find('<', pos_);
      if (lt == std::string::npos) return false;
      if (skip(lt, "<!--", "-->") || skip(lt, "<![CDATA[", "]]>") || skip(lt, "<?", "?>")) continue;
      if (text_.compare(lt, 2, "<!") == 0) {  // DOCTYPE and the like
        const std::size_t gt = text_.find('>', lt);
        pos_ = gt == std::string::npos ? text_.size() : gt + 1;
        continue;
      }
      return parse(lt, tag);
    }
  }

  int line_of(std::size_t pos) const {
    return 1 + static_cast<int>(std::count(text_.begin(), text_.begin() + static_cast<std::ptrdiff_t>(pos), '\n'));
  }

  [[noreturn]] void fail(std::size_t pos, const std::string& message) const {
    throw FileError(path_, message + " (line " + std::to_string(line_of(pos)) + ")");
  }

 private:
  bool skip(std::size_t lt, const char* open, const char* close) {
    if (text_.compare(lt, std::char_traits<char>::length(open), open) != 0) return false;
    const std::size_t end = text_.find(close, lt);
    pos_ = end == std::string::npos ? text_.size() : end + std::char_traits<char>::length(close);
    return true;
  }

  static bool name_char(char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' || c == ':';
  }

  bool parse(std::size_t lt, Tag& tag) {
    tag = Tag{};
    tag.begin = lt;
    std::size_t i = lt + 1;
    if (i < text_.size() && text_[i] == '/') {
      tag.closing = true;
      ++i;
    }
    const std::size_t name_begin = i;
    while (i < text_.size() && name_char(text_[i])) ++i;
    tag.name = text_.substr(name_begin, i - name_begin);
    // Attributes: name = "value" | 'value'.
    while (i < text_.size()) {
      while (i < text_.size() && std::isspace(static_cast<unsigned char>(text_[i]))) ++i;
      if (i >= text_.size()) break;
      if (text_[i] == '>') {
        ++i;
        break;
      }
      if (text_[i] == '/' && i + 1 < text_.size() && text_[i + 1] == '>') {
        tag.self_closing = true;
        i += 2;
        break;
      }
      const std::size_t key_begin = i;
      while (i < text_.size() && name_char(text_[i])) ++i;
      if (i == key_begin) {  // not XML we understand; let assimp judge it
        ++i;
        continue;
      }
      std::string key = text_.substr(key_begin, i - key_begin);
      while (i < text_.size() && std::isspace(static_cast<unsigned char>(text_[i]))) ++i;
      if (i >= text_.size() || text_[i] != '=') continue;
      ++i;
      while (i < text_.size() && std::isspace(static_cast<unsigned char>(text_[i]))) ++i;
      if (i >= text_.size() || (text_[i] != '"' && text_[i] != '\'')) continue;
      const char quote = text_[i++];
      const std::size_t close = text_.find(quote, i);
      if (close == std::string::npos) {
        i = text_.size();
        break;
      }
      tag.attributes.emplace_back(std::move(key), text_.substr(i, close - i));
      i = close + 1;
    }
    tag.end = i;
    pos_ = i;
    return true;
  }

  const std::string& path_;
  const std::string& text_;
  std::size_t pos_ = 0;
};

bool is_array_element(const std::string& name) {
  return name == "float_array" || name == "int_array" || name == "bool_array" || name == "Name_array" ||
         name == "IDREF_array" || name == "SIDREF_array" || name == "token_array";
}

std::string shown_char(char c) {
  char buffer[8];
  if (std::isprint(static_cast<unsigned char>(c)))
    std::snprintf(buffer, sizeof buffer, "'%c'", c);
  else
    std::snprintf(buffer, sizeof buffer, "0x%02X", static_cast<unsigned>(static_cast<unsigned char>(c)));
  return buffer;
}

}  // namespace

bool looks_like_collada(const std::string& head) { return head.find("<COLLADA") != std::string::npos; }

double check_collada(const std::string& path, const std::string& text) {
  TagScanner scanner(path, text);
  Tag tag;
  std::vector<std::string> open;  // names of the open elements
  std::vector<int> open_node;     // for each open element: index of the <node> it is, or -1
  double unit = 1.0;
  bool unit_seen = false;
  // Node graph for cycle detection: nesting and <instance_node> edges.
  std::vector<std::string> node_ids;
  std::vector<std::vector<std::pair<std::string, std::size_t>>> refs;  // per node: (target id, tag offset)
  std::vector<std::vector<int>> children;
  std::unordered_map<std::string, int> node_by_id;

  while (scanner.next(tag)) {
    if (tag.closing) {
      // Pop to the matching element (tolerating sloppy nesting; assimp judges the XML).
      auto it = std::find(open.rbegin(), open.rend(), tag.name);
      if (it != open.rend()) {
        const std::size_t keep = static_cast<std::size_t>(open.rend() - it) - 1;
        open.resize(keep);
        open_node.resize(keep);
      }
      continue;
    }
    const std::string& name = tag.name;

    if (name == "unit" && !unit_seen && open.size() == 2 && open[0] == "COLLADA" && open[1] == "asset") {
      unit_seen = true;
      if (const std::string* meter = tag.attribute("meter")) {
        std::istringstream parse(*meter);
        parse.imbue(std::locale::classic());
        double value = 0.0;
        parse >> value;
        const bool complete = !parse.fail() && (parse >> std::ws).eof();
        if (!complete || !std::isfinite(value) || value <= 0.0)
          scanner.fail(tag.begin, "<asset><unit meter=\"" + *meter + "\">: expected a positive number of metres");
        unit = value;
      }
    } else if (is_array_element(name)) {
      const std::string* count = tag.attribute("count");
      unsigned long long n = 0;
      const bool ok = count && !count->empty() &&
                      std::from_chars(count->data(), count->data() + count->size(), n).ptr == count->data() + count->size();
      if (!ok)
        scanner.fail(tag.begin, "<" + name + "> has " + (count ? "an invalid count \"" + *count + "\"" : "no count attribute"));
    } else if ((name == "p" || name == "h") && !tag.self_closing) {
      const std::size_t end = text.find("</" + name, tag.end);
      const std::size_t stop = end == std::string::npos ? text.size() : end;
      for (std::size_t i = tag.end; i < stop; ++i) {
        const char c = text[i];
        if (!std::isdigit(static_cast<unsigned char>(c)) && !std::isspace(static_cast<unsigned char>(c)) && c != '-' &&
            c != '+')
          scanner.fail(i, "<" + name + "> index list: unexpected character " + shown_char(c) + ", expected integers");
      }
    } else if (name == "instance_node") {
      const std::string* url = tag.attribute("url");
      int owner = -1;
      for (auto it = open_node.rbegin(); it != open_node.rend() && owner < 0; ++it) owner = *it;
      if (url && owner >= 0 && !url->empty() && (*url)[0] == '#') refs[owner].emplace_back(url->substr(1), tag.begin);
    }

    if (tag.self_closing) continue;
    int node = -1;
    if (name == "node") {
      node = static_cast<int>(node_ids.size());
      const std::string* id = tag.attribute("id");
      node_ids.push_back(id ? *id : std::string());
      refs.emplace_back();
      children.emplace_back();
      if (id) node_by_id.emplace(*id, node);
      int parent = -1;
      for (auto it = open_node.rbegin(); it != open_node.rend() && parent < 0; ++it) parent = *it;
      if (parent >= 0) children[parent].push_back(node);
    }
    open.push_back(name);
    open_node.push_back(node);
  }

  // Cycle through nesting and instance_node references: iterative depth-first search.
  const int n = static_cast<int>(node_ids.size());
  std::vector<std::vector<std::pair<int, std::size_t>>> edges(static_cast<std::size_t>(n));
  for (int v = 0; v < n; ++v) {
    for (int c : children[v]) edges[v].emplace_back(c, std::string::npos);
    for (const auto& [id, at] : refs[v]) {
      auto it = node_by_id.find(id);
      if (it != node_by_id.end()) edges[v].emplace_back(it->second, at);
    }
  }
  std::vector<char> state(static_cast<std::size_t>(n), 0);  // 0 new, 1 on the stack, 2 done
  for (int root = 0; root < n; ++root) {
    if (state[root]) continue;
    std::vector<std::pair<int, std::size_t>> stack{{root, 0}};
    state[root] = 1;
    while (!stack.empty()) {
      auto& [v, k] = stack.back();
      if (k == edges[v].size()) {
        state[v] = 2;
        stack.pop_back();
        continue;
      }
      const auto [w, at] = edges[v][k++];
      if (state[w] == 1)
        scanner.fail(at == std::string::npos ? 0 : at,
                     "<instance_node> references make a cycle through node \"" + node_ids[w] + "\"");
      if (state[w] == 0) {
        state[w] = 1;
        stack.emplace_back(w, 0);
      }
    }
  }
  return unit;
}

}  // namespace pairgrasp::detail
