#include "commands.hpp"

namespace strata::cli {

const char* UsageText() {
  return R"(usage: strata [--server HOST:PORT] [--deadline S] [--json] COMMAND ...

Global flags (anywhere on the line):
  --server HOST:PORT   strata-server address (default $STRATA_SERVER, else 127.0.0.1:50051)
  --deadline S         deadline of each call in seconds (default 30)
  --json               print responses as JSON (proto field names; errors as JSON on stderr)

Commands:
  maps create [ID] (--file PATH | --scene NAME [--seed N]) [TERRAIN] [--wait]
  maps upload ID FILE [--format pcd|xyz|raw] [--chunk-points N] [TERRAIN] [--wait]
  maps get ID
  maps list [--page-size N] [--page-token T]
  maps delete ID
  plan --map ID --start x,y,z --goal x,y,z [--robot NAME] [--time-budget S] [--sample-dt S]
  setpoints (--from PLAN.json | PLAN FLAGS) [--t0 S] [--dt S] [--steps N]
            [--min-speed-for-yaw MPS]

  TERRAIN: [--resolution M] [--ground-radius M] [--max-tilt RAD] [--height-tolerance M]
           [--padding M]

Exit codes: 0 success, 1 the server answered with an error (or could not be reached),
2 bad arguments or an unusable input file. See client/README.md.
)";
}

}  // namespace strata::cli
