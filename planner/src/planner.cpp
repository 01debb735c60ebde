#include "strata/planner.hpp"
