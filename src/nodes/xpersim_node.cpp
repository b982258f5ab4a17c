// XPERSim as a stand-alone process.
#include "xpersif/component/shells.h"
#include "xpersif/xpersim/xpersim.h"

int main(int argc, char** argv) { return xpersif::runComponentNode<xpersif::XPerSim>(argc, argv, "xpersim"); }
