// strata: the command-line client of strata-server. See client/README.md.
#include <cstdlib>
#include <exception>
#include <iostream>

#include "arguments.hpp"
#include "commands.hpp"
#include "context.hpp"

namespace strata::cli {
namespace {

int Run(int argc, const char* const* argv) {
  Arguments args(argc, argv, {"json", "wait", "help"});
  Context ctx;
  if (const char* server = std::getenv("STRATA_SERVER"); server != nullptr && *server != '\0') {
    ctx.server = server;
  }
  ctx.server = args.Take("server").value_or(ctx.server);
  ctx.deadline_s = args.TakeDouble("deadline").value_or(ctx.deadline_s);
  if (ctx.deadline_s <= 0) throw UsageError("--deadline must be > 0 s");
  ctx.json = args.TakeBool("json");
  if (args.TakeBool("help")) {
    std::cout << UsageText();
    return kExitOk;
  }
  const auto command = args.NextPositional();
  if (!command) throw UsageError("no command given");
  if (*command == "help") {
    std::cout << UsageText();
    return kExitOk;
  }
  if (*command == "maps") return RunMaps(ctx, args);
  if (*command == "plan") return RunPlan(ctx, args);
  if (*command == "setpoints") return RunSetpoints(ctx, args);
  throw UsageError("unknown command \"" + *command + "\"");
}

}  // namespace
}  // namespace strata::cli

int main(int argc, char** argv) {
  try {
    return strata::cli::Run(argc, argv);
  } catch (const strata::cli::UsageError& error) {
    std::cerr << "strata: " << error.what() << "\n(strata --help shows the usage)\n";
    return strata::cli::kExitUsage;
  } catch (const std::exception& error) {
    std::cerr << "strata: " << error.what() << "\n";
    return strata::cli::kExitUsage;
  }
}
