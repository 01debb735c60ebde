#include "strata/trajectory_verifier.hpp"
