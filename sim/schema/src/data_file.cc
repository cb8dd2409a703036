// Regular files of a bounded size, and JSON of a bounded depth.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "forklift/schema/data_file.h"

namespace forklift::schema {
namespace {

std::string size_words(size_t bytes) {
  if (bytes >= (size_t{1} << 20)) return std::to_string(bytes >> 20) + " MiB";
  if (bytes >= (size_t{1} << 10)) return std::to_string(bytes >> 10) + " KiB";
  return std::to_string(bytes) + " bytes";
}

std::optional<std::string> stat_problem(const struct stat& st, size_t max_bytes) {
  if (S_ISDIR(st.st_mode)) return "is a folder, not a file";
  if (!S_ISREG(st.st_mode)) return "is not a regular file (a pipe, socket or device is not read)";
  if (static_cast<unsigned long long>(st.st_size) > max_bytes)
    return "is " + size_words(st.st_size) + ", more than the " + size_words(max_bytes) + " a data file may have";
  return std::nullopt;
}

// The deepest nesting of arrays and objects in `text`, counting brackets outside strings; stops
// counting once past `limit`.
int nesting_depth(const std::string& text, int limit) {
  int depth = 0, deepest = 0;
  bool in_string = false, escaped = false;
  for (char c : text) {
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
      if (deepest > limit) return deepest;
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return deepest;
}

}  // namespace

std::optional<std::string> file_problem(const std::string& path, size_t max_bytes) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return std::string("cannot be read: ") + std::strerror(errno);
  return stat_problem(st, max_bytes);
}

std::string read_file(const std::string& path, size_t max_bytes) {
  // O_NONBLOCK: if a pipe takes the file's place between a check and the open, the open must not
  // wait for a writer; the fstat below then refuses it.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw DataFileError(path + ": cannot open: " + std::strerror(errno));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw DataFileError(path + ": cannot read: " + std::strerror(errno));
  if (const auto problem = stat_problem(st, max_bytes)) throw DataFileError(path + ": " + *problem);
  std::string text;
  text.resize(static_cast<size_t>(st.st_size));
  size_t have = 0;
  while (have < text.size()) {
    const ssize_t n = ::read(fd, text.data() + have, text.size() - have);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw DataFileError(path + ": cannot read: " + std::strerror(errno));
    if (n == 0) break;  // shrank while read: take what is there
    have += static_cast<size_t>(n);
  }
  text.resize(have);
  return text;
}

nlohmann::json read_json(const std::string& path) {
  const std::string text = read_file(path, kMaxJsonBytes);
  if (nesting_depth(text, kMaxJsonDepth) > kMaxJsonDepth)
    throw DataFileError(path + ": nests arrays and objects more than " + std::to_string(kMaxJsonDepth) + " deep");
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw DataFileError(path + ": not valid JSON: " + e.what());
  }
}

nlohmann::json read_checked_json(const std::string& path, Schema schema) {
  nlohmann::json doc = read_json(path);
  if (const auto problem = schema_problem(doc, schema)) throw DataFileError(path + ": " + *problem);
  return doc;
}

}  // namespace forklift::schema
