// A plugin written for SDK 1 names locsim::sdk::WheelTravel: compiled against this SDK, the
// compiler's message says what replaces it (test SdkRemovedNameSaysWhatReplacesIt).
#include <locsim/models.hpp>

double travel(double wheel_base_m) {
  locsim::sdk::WheelTravel tracker(wheel_base_m);
  (void)tracker;
  return wheel_base_m;
}
