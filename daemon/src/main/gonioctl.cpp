// gonioctl — see gonio/daemon/ctl/ctl.hpp.
#include "gonio/daemon/ctl/ctl.hpp"

int main(int argc, char** argv) { return gonio::daemon::gonioctl_main(argc, argv); }
