// The example counter component as a stand-alone process.
#include "xpersif/component/shells.h"
#include "xpersif/examples/example_counter.h"

int main(int argc, char** argv) {
  return xpersif::runComponentNode<xpersif::ExampleCounter>(argc, argv, "example_counter");
}
