// Broken on purpose: the entry function returns no description.
#include "tether/plugins/plugin.h"

extern "C" __attribute__((visibility("default"))) const tether::PluginDescription* tether_plugin_entry() {
  return nullptr;
}
