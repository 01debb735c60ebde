// The strata command line as a whole: global flags, commands, help.
#include "commands.hpp"

namespace strata::cli {

void AddStrataCommands(CLI::App& app, Context* ctx, Command* run) {
  app.description("strata: the command-line client of strata-server. See client/README.md.");
  app.footer(
      "`strata COMMAND --help` shows a command's flags, `strata --help-all` every command's.\n"
      "Global flags go anywhere on the line, a command's flags after its name.\n"
      "Exit codes: 0 success, 1 the server answered with an error (or could not be reached),\n"
      "2 bad arguments or an unusable input file.");
  app.set_help_flag("-h,--help", "print this help and exit");
  app.set_help_all_flag("--help-all", "print the help of every command and exit");
  app.fallthrough();  // Global flags after a command's name too.

  app.add_option("--server", ctx->server, "strata-server address")
      ->type_name("HOST:PORT")
      ->envname("STRATA_SERVER")
      ->capture_default_str();
  app.add_option("--deadline", ctx->deadline_s, "deadline of each call in seconds")
      ->type_name("S")
      ->check(PositiveNumber())
      ->capture_default_str();
  app.add_option("--token", ctx->token,
                 "bearer token for a server run with --auth-tokens (better: $STRATA_TOKEN, which "
                 "other users cannot read in the process list)")
      ->type_name("TOKEN")
      ->envname("STRATA_TOKEN");
  app.add_option("--tls-ca", ctx->tls_ca,
                 "connect with TLS, trusting the server certificate's CA in this PEM file")
      ->type_name("FILE")
      ->envname("STRATA_TLS_CA")
      ->check(CLI::ExistingFile);
  app.add_flag("--json", ctx->json,
               "print responses as JSON (proto field names; errors as JSON on stderr)");

  AddMapsCommands(app, *ctx, run);
  AddPlanCommand(app, *ctx, run);
  AddSetpointsCommand(app, *ctx, run);
  AddCostsCommand(app, *ctx, run);
  AddBatchCommand(app, *ctx, run);
  AddReservationsCommands(app, *ctx, run);
  app.add_subcommand("help", "print this help")->callback([&app, run] {
    *run = [&app] {
      // Not app.help(), which shows the help of the command given: `help` itself.
      std::cout << app.get_formatter()->make_help(&app, app.get_name(), CLI::AppFormatMode::Normal);
      return kExitOk;
    };
  });
}

}  // namespace strata::cli
