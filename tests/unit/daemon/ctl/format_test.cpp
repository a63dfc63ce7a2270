// gonioctl's text output and exit codes.
#include <gtest/gtest.h>

#include "gonio/daemon/ctl/ctl.hpp"
#include "gonio/daemon/rpc/rpc.hpp"

namespace gonio::daemon {
namespace {

TEST(Table, AlignsColumnsNumbersRight) {
  Table t({"id", "name", "β"});
  t.add({"7", "tile", "0.25"});
  t.add({"12", "glossy-demo", "1.5"});
  EXPECT_EQ(t.render(),
            "id  name            β\n"
            " 7  tile         0.25\n"
            "12  glossy-demo   1.5\n");
}

TEST(ProgressBar, ShowsCountsPercentEtaAndDivergence) {
  EXPECT_EQ(progress_bar(5, 10, 65, 2, 10), "[#####·····]  5/10   50 %  ETA 1:05  diverged 2");
  EXPECT_EQ(progress_bar(10, 10, 3, 0, 4), "[####] 10/10  100 %  ETA 0:00  diverged 0");
  EXPECT_EQ(progress_bar(0, 0, 0, 0, 2), "[··] 0/0    0 %  ETA 0:00  diverged 0");
}

TEST(Durations, Format) {
  EXPECT_EQ(format_duration(0), "0:00");
  EXPECT_EQ(format_duration(59.6), "1:00");
  EXPECT_EQ(format_duration(3725), "1:02:05");
  EXPECT_EQ(format_duration(-1), "-");
}

TEST(Cells, RenderJsonValues) {
  EXPECT_EQ(cell(nullptr), "-");
  EXPECT_EQ(cell(true), "yes");
  EXPECT_EQ(cell(42), "42");
  EXPECT_EQ(cell(0.123456), "0.1235");
  EXPECT_EQ(cell("text"), "text");
}

TEST(ExitCodes, FollowTheServerCode) {
  EXPECT_EQ(exit_code_for_rpc(rpc::code::invalid_params), ctl_exit::usage);
  EXPECT_EQ(exit_code_for_rpc(rpc::code::unauthorized), ctl_exit::auth);
  EXPECT_EQ(exit_code_for_rpc(rpc::code::forbidden), ctl_exit::auth);
  EXPECT_EQ(exit_code_for_rpc(rpc::code::not_found), ctl_exit::not_found);
  EXPECT_EQ(exit_code_for_rpc(rpc::code::instrument_busy), ctl_exit::state);
  EXPECT_EQ(exit_code_for_rpc(rpc::code::instrument_fault), ctl_exit::instrument);
  EXPECT_EQ(exit_code_for_rpc(rpc::code::plan_rejected), ctl_exit::plan);
  EXPECT_EQ(exit_code_for_rpc(rpc::code::internal_error), ctl_exit::internal);
  EXPECT_EQ(exit_code_for_rpc(-32050), ctl_exit::server);
}

}  // namespace
}  // namespace gonio::daemon
