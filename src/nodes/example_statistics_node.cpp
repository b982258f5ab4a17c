// The example aggregate component as a stand-alone process.
#include "xpersif/component/shells.h"
#include "xpersif/examples/example_statistics.h"

int main(int argc, char** argv) {
  return xpersif::runComponentNode<xpersif::ExampleStatistics>(argc, argv, "example_statistics");
}
