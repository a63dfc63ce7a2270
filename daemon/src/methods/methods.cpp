// goniod's JSON-RPC methods, assembled: each family registers its handlers (methods/*.cpp)
// against the one method table (gonio/daemon/methods/method_table.hpp), which gives every method its
// role and whether it blocks.
#include "gonio/daemon/methods/methods.hpp"

#include "methods/registrar.hpp"

namespace gonio::daemon {

void register_methods(rpc::Dispatcher& d, Services& s) {
  MethodRegistrar reg(d);
  register_auth(reg, s);
  register_system(reg, s);
  register_instrument(reg, s);
  register_sample(reg, s);
  register_scan(reg, s);
  register_material(reg, s);
  register_queue(reg, s);
  register_alert(reg, s);
  register_archive(reg, s);
  register_backup(reg, s);
  register_twin(reg, s);
  register_subscribe(reg, s);
  reg.finish();
}

}  // namespace gonio::daemon
