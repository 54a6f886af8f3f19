#include "ips/ranging/speed_of_sound.h"

#include <cmath>

namespace ips {

double speed_of_sound(double temperature_c) { return 331.3 * std::sqrt(1.0 + temperature_c / 273.15); }

double ultrasound_range_scale(double temperature_c, double assumed_speed) {
  return speed_of_sound(temperature_c) / assumed_speed;
}

}  // namespace ips
