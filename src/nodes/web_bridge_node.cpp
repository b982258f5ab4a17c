// WebBridge as a stand-alone process (launch/view.launch web:=true: a browser viewer of a running job).
#include "xpersif/component/shells.h"
#include "xpersif/web/web_bridge.h"

int main(int argc, char** argv) { return xpersif::runComponentNode<xpersif::WebBridge>(argc, argv, "web_bridge"); }
