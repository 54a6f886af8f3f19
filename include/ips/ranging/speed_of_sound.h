// Ultrasound ranges and the air's temperature. A time-of-flight module reports
// d = ToF * c_assumed; sound travels at c(T) = 331.3 sqrt(1 + T / 273.15) m/s in dry air at
// T degrees Celsius (the formula Petkovic et al. 2016 use), so a module that assumes 343 m/s
// reads 0.6 % short at 30 degC (6 mm at 1 m). The true range is d * c(T) / c_assumed.
#pragma once

namespace ips {

/// Speed of sound in dry air at `temperature_c` degrees Celsius, m/s.
double speed_of_sound(double temperature_c);

/// What an ultrasound range measured with `assumed_speed` (m/s) is multiplied by at
/// `temperature_c`: speed_of_sound(temperature_c) / assumed_speed.
double ultrasound_range_scale(double temperature_c, double assumed_speed);

}  // namespace ips
