// The backup.* methods: a consistent copy of the store, made while scans run, handed to the
// client in pieces.
//
// backup.create makes the copy (Store::backup_to: SQLite's online backup API from one read
// snapshot) into a file of its own in the state directory and answers with its size and
// SHA-256; backup.read returns it by offset, base64 in the JSON, and removes the file once
// its last byte has been read. The client may be on another host and use any transport (the
// state directory's socket, NDJSON over TCP, HTTP): nothing but JSON-RPC crosses, each answer
// stays under the response limit, and a lost answer is asked for again by its offset (all but
// the last: the copy goes once its end has been served). A copy left unread for kUnclaimed is
// removed; so are copies left by an earlier goniod.
#include <chrono>
#include <fstream>
#include <map>
#include <mutex>
#include <random>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "gonio/daemon/rpc/transfer.hpp"
#include "methods/params.hpp"
#include "methods/registrar.hpp"

namespace gonio::daemon {

using json_util::ObjectReader;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

constexpr auto kUnclaimed = std::chrono::minutes(30);
constexpr std::size_t kDefaultPiece = 1 << 20;
constexpr std::size_t kMaxPiece = 4 << 20;  // 5.6 MB of base64: under the default response limit
constexpr const char* kPrefix = "backup-";
constexpr const char* kSuffix = ".db.part";

// The copies made and not yet read to their end.
class Copies {
 public:
  explicit Copies(fs::path dir) : dir_(std::move(dir)) {
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir_, ec)) {
      const auto name = e.path().filename().string();
      if (name.starts_with(kPrefix) && name.ends_with(kSuffix)) fs::remove(e.path(), ec);
    }
  }
  ~Copies() {
    std::error_code ec;
    for (const auto& [id, c] : copies_) fs::remove(c.file, ec);
  }
  Copies(const Copies&) = delete;
  Copies& operator=(const Copies&) = delete;

  // A fresh id and the file for it.
  std::pair<std::string, fs::path> reserve() {
    std::lock_guard lock(mu_);
    expire();
    const auto id = fmt::format("{:016x}", rng_());
    return {id, dir_ / fmt::format("{}{}{}", kPrefix, id, kSuffix)};
  }
  void add(const std::string& id, fs::path file, std::uint64_t bytes) {
    std::lock_guard lock(mu_);
    copies_[id] = Copy{std::move(file), bytes, std::chrono::steady_clock::now()};
  }
  // The file and size of copy `id`; Error(not_found) naming "backup".
  std::pair<fs::path, std::uint64_t> find(const std::string& id) {
    std::lock_guard lock(mu_);
    expire();
    const auto it = copies_.find(id);
    if (it == copies_.end())
      throw Error::not_found("backup", fmt::format("backup '{}' (read to its end, expired after {} min, or never made)",
                                                   id, std::chrono::duration_cast<std::chrono::minutes>(kUnclaimed).count()));
    it->second.touched = std::chrono::steady_clock::now();
    return {it->second.file, it->second.bytes};
  }
  void remove(const std::string& id) {
    std::lock_guard lock(mu_);
    if (const auto it = copies_.find(id); it != copies_.end()) {
      std::error_code ec;
      fs::remove(it->second.file, ec);
      copies_.erase(it);
    }
  }

 private:
  struct Copy {
    fs::path file;
    std::uint64_t bytes = 0;
    std::chrono::steady_clock::time_point touched;
  };
  void expire() {
    const auto now = std::chrono::steady_clock::now();
    std::error_code ec;
    for (auto it = copies_.begin(); it != copies_.end();) {
      if (now - it->second.touched < kUnclaimed) {
        ++it;
        continue;
      }
      fs::remove(it->second.file, ec);
      it = copies_.erase(it);
    }
  }
  fs::path dir_;
  std::mutex mu_;
  std::map<std::string, Copy> copies_;
  std::mt19937_64 rng_{std::random_device{}()};
};

// Refuses a copy that would eat into the room the store keeps for its own writes.
void check_room(const Store& store) {
  const auto st = store.storage();
  std::error_code ec;
  std::uint64_t size = fs::file_size(store.path(), ec);
  const auto wal = fs::file_size(store.path().string() + "-wal", ec);
  if (!ec) size += wal;
  const auto need = size + st.min_free_bytes + Store::kReserveBytes;
  if (st.space.known && (st.space.read_only || st.space.free_bytes < need))
    throw Error(Errc::storage_unavailable,
                fmt::format("no room for a copy of the store: it needs {:.1f} MiB besides store.min_free_mb and "
                            "the reserve; {}",
                            static_cast<double>(size) / (1 << 20), describe_space(st.dir, st.space)));
}

}  // namespace

void register_backup(MethodRegistrar& reg, Services& s) {
  auto copies = std::make_shared<Copies>(s.state_dir);

  reg.add("backup.create", [&s, copies](rpc::Call& c) {
    ObjectReader(c.params, "").finish();
    check_room(s.store);
    const auto [id, file] = copies->reserve();
    const auto info = s.store.backup_to(file);
    std::string sha;
    try {
      sha = sha256_file(file);
    } catch (...) {
      std::error_code ec;
      fs::remove(file, ec);
      throw;
    }
    copies->add(id, file, info.bytes);
    s.store.audit(methods::actor(c), "backup.create", "",
                  json{{"bytes", info.bytes}, {"sha256", sha}, {"points", info.points}});
    spdlog::info("backup {}: {} bytes, {} scans, {} points, in {:.2f} s", id, info.bytes, info.scans, info.points,
                 info.seconds);
    return json{{"backup", id},
                {"bytes", info.bytes},
                {"sha256", sha},
                {"schema_version", info.schema_version},
                {"scans", info.scans},
                {"points", info.points},
                {"seconds", info.seconds},
                {"created_at", utc::now()}};
  });

  reg.add("backup.read", [copies](rpc::Call& c) {
    ObjectReader r(c.params, "");
    const auto id = r.required<std::string>("backup");
    const auto offset = r.optional_in<std::uint64_t>("offset", 0, 0, std::uint64_t{1} << 50);
    const auto length = r.optional_in<std::size_t>("length", kDefaultPiece, 1, kMaxPiece, " bytes");
    r.finish();
    const auto [file, size] = copies->find(id);
    if (offset > size) throw Error::out_of_range("offset", static_cast<double>(offset), 0, static_cast<double>(size));
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(length, size - offset));
    std::string bytes(n, '\0');
    std::ifstream in(file, std::ios::binary);
    in.seekg(static_cast<std::streamoff>(offset));
    if (!in.read(bytes.data(), static_cast<std::streamsize>(n)))
      throw Error(Errc::io_error, fmt::format("cannot read {}", file.string()), "backup");
    const bool eof = offset + n == size;
    if (eof) copies->remove(id);
    // Written as text, with room for the envelope (rpc::response_text): base64 needs no
    // escaping, and a JSON tree of the piece cost a copy and a character-by-character dump
    // of 1.4 MB per call. The id is one this goniod made (16 hex digits).
    std::string out;
    out.reserve(4 * n / 3 + 256);
    out += fmt::format(R"({{"backup":"{}","offset":{},"bytes":{},"eof":{},"data":")", id, offset, n, eof);
    out += base64_encode(bytes);
    out += "\"}";
    return rpc::Result(rpc::RawJson(std::move(out)));
  });
}

}  // namespace gonio::daemon
