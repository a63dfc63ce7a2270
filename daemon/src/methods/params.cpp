// Shared parameter readers and lookups of the method families.
#include "methods/params.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstring>
#include <optional>

#include <fmt/format.h>

namespace gonio::daemon::methods {

using json_util::ObjectReader;
using nlohmann::json;

namespace {

bool ident_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-'; }
bool path_char(char c) { return ident_char(c) || c == '.' || c == '/'; }

// Where a '@' path ends as the twin's spec parser sees it: at a ',' that opens the next
// key=value argument or a '+' that opens the next lobe. A ',' or '+' that would continue
// the name (the parser keeps it) is refused rather than second-guessed.
std::size_t path_end(const std::string& spec, std::size_t begin, const std::string& field) {
  std::size_t end = begin;
  while (end < spec.size() && path_char(spec[end])) ++end;
  if (end == spec.size()) return end;
  const char c = spec[end];
  std::size_t k = end + 1;
  while (k < spec.size() && std::isspace(static_cast<unsigned char>(spec[k]))) ++k;
  if (c == ',') {
    const auto next = spec.find_first_of(",+", k);
    if (spec.substr(k, next - k).find('=') != std::string::npos) return end;
  } else if (c == '+') {
    if (k < spec.size() && (spec[k] == '@' || std::isalpha(static_cast<unsigned char>(spec[k])))) return end;
  } else if (std::isspace(static_cast<unsigned char>(c))) {
    while (k < spec.size() && std::isspace(static_cast<unsigned char>(spec[k]))) ++k;
    if (k == spec.size() || spec[k] == '+' || spec[k] == ',') return end;
  }
  throw Error::invalid(field, "a file name after '@' may hold only letters, digits, '.', '_', '-' and '/'");
}

}  // namespace

std::string confine_bsdf_files(const std::string& spec, const std::filesystem::path& data_dir,
                               const std::string& field) {
  std::string out;
  std::size_t from = 0;
  for (auto at = spec.find('@'); at != std::string::npos; at = spec.find('@', from)) {
    const auto end = path_end(spec, at + 1, field);
    const std::string rel = spec.substr(at + 1, end - at - 1);
    if (rel.empty() || rel.front() == '/')
      throw Error::invalid(field, fmt::format("'@{}': give a file name relative to the data directory {} "
                                              "(twin.data_dir)", rel, data_dir.string()));
    // Walk the components without following links: "..", links and non-regular files are out.
    int dir = ::open(data_dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dir < 0)
      throw Error::invalid(field, fmt::format("'@{}': the data directory {} (twin.data_dir) cannot be "
                                              "opened: {}", rel, data_dir.string(), std::strerror(errno)));
    std::size_t p = 0;
    for (;;) {
      const auto slash = rel.find('/', p);
      const std::string part = rel.substr(p, slash == std::string::npos ? std::string::npos : slash - p);
      const bool last = slash == std::string::npos;
      if (part.empty() || part == "." || part == "..") {
        ::close(dir);
        throw Error::invalid(field, fmt::format("'@{}': '.', '..' and empty path components are not allowed", rel));
      }
      const int fd = ::openat(dir, part.c_str(),
                              O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK | (last ? 0 : O_DIRECTORY));
      const int err = errno;
      ::close(dir);
      if (fd < 0)
        throw Error::invalid(field, fmt::format("'@{}': {} in the data directory {} ({})", rel,
                                                err == ELOOP || err == ENOTDIR ? "not a plain file or directory (no links)"
                                                                               : std::strerror(err),
                                                data_dir.string(), part));
      if (last) {
        struct stat st {};
        const bool regular = ::fstat(fd, &st) == 0 && S_ISREG(st.st_mode);
        ::close(fd);
        if (!regular) throw Error::invalid(field, fmt::format("'@{}' is not a regular file", rel));
        break;
      }
      dir = fd;
      p = slash + 1;
    }
    out += spec.substr(from, at + 1 - from);
    out += (data_dir / rel).string();
    from = end;
  }
  out += spec.substr(from);
  return out;
}

std::int64_t read_id(ObjectReader& r, const std::string& key) {
  const auto v = r.required<std::int64_t>(key);
  if (v <= 0) throw Error::invalid(r.path(key), fmt::format("{} is not an id (ids are >= 1)", v));
  return v;
}

std::size_t read_count(ObjectReader& r, const std::string& key, std::size_t fallback,
                       std::size_t max) {
  return static_cast<std::size_t>(r.optional_in<long long>(key, static_cast<long long>(fallback), 0,
                                                           static_cast<long long>(max)));
}

std::size_t read_offset(ObjectReader& r) {
  return read_count(r, "offset", 0, static_cast<std::size_t>(1) << 40);
}

Sample resolve_sample(const Store& store, const json& ref, const std::string& field) {
  std::optional<Sample> s;
  if (ref.is_number_integer()) {
    const auto id = ref.get<std::int64_t>();
    s = store.sample(id);
    if (!s) throw Error::not_found(field, fmt::format("sample {}", id));
  } else if (ref.is_string()) {
    const auto name = ref.get<std::string>();
    s = store.sample_by_name(name);
    if (!s) throw Error::not_found(field, fmt::format("sample '{}'", name));
  } else {
    throw Error::invalid(field, "expected a sample id or name, got " + json_util::type_name(ref));
  }
  return *s;
}

Scan require_scan(const Store& store, std::int64_t id) {
  auto s = store.scan(id);
  if (!s) throw Error::not_found("scan", fmt::format("scan {}", id));
  return *s;
}

std::string actor(const rpc::Call& c) { return c.principal.name; }

void write_principal(JsonWriter& w, const Principal& p) {
  w.member("name", p.name).member("role", to_text(p.role)).member("transport", p.transport);
}

json principal_json(const Principal& p) {
  return json{{"name", p.name}, {"role", to_text(p.role)}, {"transport", p.transport}};
}

json scan_summary(const Scan& s) { return to_json(s, false); }

}  // namespace gonio::daemon::methods
