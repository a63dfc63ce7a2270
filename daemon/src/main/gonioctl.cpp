// gonioctl — see gonio/daemon/ctl.hpp.
#include "gonio/daemon/ctl.hpp"

int main(int argc, char** argv) { return gonio::daemon::gonioctl_main(argc, argv); }
