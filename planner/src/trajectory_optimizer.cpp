#include "strata/trajectory_optimizer.hpp"
