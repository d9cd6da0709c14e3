// Broken on purpose: the description has no registration function.
#include "tether/plugins/plugin.h"

TETHER_PLUGIN("test_no_register_function", "0.1.0", nullptr)
