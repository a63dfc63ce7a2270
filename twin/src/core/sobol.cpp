#include "gonio/twin/detail/core/sobol.hpp"

#include <memory>
#include <mutex>

#include <boost/random/sobol.hpp>

namespace gonio::twin::detail {

const std::vector<std::uint32_t>& SobolTable::get(std::uint64_t points) {
  static std::mutex mutex;
  // Old tables are kept so that references handed out earlier stay valid.
  static std::vector<std::unique_ptr<const std::vector<std::uint32_t>>> tables;
  std::lock_guard lock(mutex);
  if (!tables.empty() && tables.back()->size() >= points * kSobolDims) return *tables.back();
  std::uint64_t n = 1u << 12;
  while (n < points) n <<= 1;
  auto table = std::make_unique<std::vector<std::uint32_t>>(n * kSobolDims, 0u);
  // Boost's engine starts at point 1 (it skips the origin); point 0 stays all zeros.
  boost::random::sobol_engine<std::uint32_t, 32> engine(kSobolDims);
  for (std::uint64_t i = 1; i < n; ++i)
    for (int d = 0; d < kSobolDims; ++d) (*table)[i * kSobolDims + d] = engine();
  tables.push_back(std::move(table));
  return *tables.back();
}

}  // namespace gonio::twin::detail
