// The generic organizational component as a stand-alone process.
#include "xpersif/component/shells.h"
#include "xpersif/component/supervisor.h"

int main(int argc, char** argv) { return xpersif::runComponentNode<xpersif::Supervisor>(argc, argv, "supervisor"); }
