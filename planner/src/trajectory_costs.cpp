#include "strata/trajectory_costs.hpp"
