// MethodRegistrar: attaches the handlers of daemon/src/methods/*.cpp to the entries of the
// method table (gonio/daemon/methods/method_table.hpp), which alone gives each method its role and
// whether it blocks; and the register_<area> function of each method family.
#pragma once

#include <set>
#include <string>
#include <string_view>

#include "gonio/daemon/methods/methods.hpp"
#include "gonio/daemon/rpc/rpc.hpp"

namespace gonio::daemon {

class MethodRegistrar {
 public:
  explicit MethodRegistrar(rpc::Dispatcher& d) : d_(d) {}

  // Adds the method `name` with the role and blocking of its table entry. Throws
  // Error(internal) when the table has no such method or it already has a handler.
  void add(std::string_view name, rpc::Handler handler);
  // Throws Error(internal) naming the table entries that got no handler.
  void finish() const;

 private:
  rpc::Dispatcher& d_;
  std::set<std::string, std::less<>> added_;
};

// One per method family, each in its own file (methods/<area>.cpp).
void register_auth(MethodRegistrar& r, Services& s);        // rpc.discover, auth.*
void register_system(MethodRegistrar& r, Services& s);      // system.*
void register_instrument(MethodRegistrar& r, Services& s);  // instrument.*
void register_sample(MethodRegistrar& r, Services& s);      // sample.*
void register_scan(MethodRegistrar& r, Services& s);        // scan.*
void register_material(MethodRegistrar& r, Services& s);    // scan.material
void register_queue(MethodRegistrar& r, Services& s);       // queue.*
void register_alert(MethodRegistrar& r, Services& s);       // alert.*
void register_archive(MethodRegistrar& r, Services& s);     // archive.*
void register_backup(MethodRegistrar& r, Services& s);      // backup.*
void register_twin(MethodRegistrar& r, Services& s);        // twin.*
void register_subscribe(MethodRegistrar& r, Services& s);   // subscribe, unsubscribe

}  // namespace gonio::daemon
