// The only file that includes qhull's headers (their macros stay here).
#include "convex_hull.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <new>

extern "C" {
#include <libqhull_r/qhull_ra.h>
}

namespace pairgrasp::detail {

namespace {

/// qhull's messages go to a memory stream, never to the process's stderr.
class MessageStream {
 public:
  MessageStream() : file_(open_memstream(&buffer_, &size_)) {}
  ~MessageStream() {
    if (file_) std::fclose(file_);
    std::free(buffer_);
  }
  MessageStream(const MessageStream&) = delete;
  MessageStream& operator=(const MessageStream&) = delete;
  FILE* file() const { return file_; }
  /// The first non-empty line written so far.
  std::string first_line() {
    if (!file_) return "";
    std::fflush(file_);
    const std::string all(buffer_ ? buffer_ : "", size_);
    std::size_t begin = all.find_first_not_of(" \t\r\n");
    if (begin == std::string::npos) return "";
    return all.substr(begin, all.find('\n', begin) - begin);
  }

 private:
  char* buffer_ = nullptr;
  std::size_t size_ = 0;
  FILE* file_ = nullptr;
};

/// One qhull state, freed whatever happened.
struct Qhull {
  qhT state;
  explicit Qhull(FILE* err) { qh_zero(&state, err); }
  ~Qhull() {
    int curlong = 0, totlong = 0;
    qh_freeqhull(&state, !qh_ALL);
    qh_memfreeshort(&state, &curlong, &totlong);
  }
  Qhull(const Qhull&) = delete;
  Qhull& operator=(const Qhull&) = delete;
};

}  // namespace

bool convex_hull(const double* points, int n, int dim, const std::string& options, bool volume, ConvexHull& out,
                 std::string& error) {
  std::vector<coordT> coords(points, points + static_cast<std::size_t>(n) * dim);  // qhull may rescale it
  std::string command = "qhull " + options + (volume ? " FA" : "");
  MessageStream messages;
  FILE* err = messages.file() ? messages.file() : stderr;
  auto owner = std::make_unique<Qhull>(err);
  qhT* qh = &owner->state;
  const int code = qh_new_qhull(qh, dim, n, coords.data(), False, command.data(), nullptr, err);
  if (code == qh_ERRmem) throw std::bad_alloc();
  if (code != 0) {
    error = messages.first_line();
    if (error.empty()) error = "qhull exit code " + std::to_string(code);
    return false;
  }
  facetT* facet = nullptr;
  int count = 0;
  FORALLfacets {
    if (facet->normal) ++count;
  }
  out.planes.resize(count, dim + 1);
  int row = 0;
  FORALLfacets {
    if (!facet->normal) continue;
    for (int k = 0; k < dim; ++k) out.planes(row, k) = facet->normal[k];
    out.planes(row, dim) = facet->offset;
    ++row;
  }
  out.volume = volume ? static_cast<double>(qh->totvol) : 0.0;
  out.vertices.clear();
  vertexT* vertex = nullptr;
  FORALLvertices out.vertices.push_back(qh_pointid(qh, vertex->point));
  std::sort(out.vertices.begin(), out.vertices.end());
  return true;
}

}  // namespace pairgrasp::detail
