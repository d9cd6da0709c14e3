// Broken on purpose: a shared library without the entry symbol. It exports a function with a
// similar (misspelt) name, as a real mistake would.
#include "tether/plugins/plugin.h"

extern "C" __attribute__((visibility("default"))) const tether::PluginDescription* tether_plugins_entry() {
  return nullptr;
}
