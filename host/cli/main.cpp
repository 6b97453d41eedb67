// Entry point of the volcl executable: parses the command line and turns exceptions into exit codes.
#include "host/Error.hpp"
#include "host/PrintableMessage.hpp"
#include "host/cli/Commands.hpp"

#include <csignal>
#include <iostream>

int main(int argc, char** argv) {
    // Over a file size limit (ulimit -f) a write then fails with EFBIG and ends in a clean IoError, instead
    // of SIGXFSZ killing the process before it can report anything.
    std::signal(SIGXFSZ, SIG_IGN);
    CLI::App app{"volcl: OpenCL volume processing (codec, pre-integration, ray marching)", "volcl"};
    app.require_subcommand(1);
    volcl::cli::GlobalOptions global;
    app.add_option("--device", global.device, "OpenCL device: index or name substring (default $VOLCL_DEVICE)");
    app.add_flag("-q,--quiet", global.quiet, "No progress output");
    CLI::App* bench = app.add_subcommand("bench", "Benchmarks: speed and accuracy against peers");
    bench->require_subcommand(1);

    volcl::cli::addInfoCommands(app, global);
    volcl::cli::addDemoCommand(app, global);
    volcl::cli::addViewCommand(app, *bench, global);
    volcl::cli::addPreintCommands(app, *bench, global);
    volcl::cli::addRenderCommands(app, *bench, global);
    volcl::cli::addCodecCommands(app, *bench, global);

    // The single place where errors become messages and exit codes (CONTRACT section 5).
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        std::cerr << "volcl: " << volcl::printableMessage(e.what()) << " (see volcl --help)\n";
        return 2;
    } catch (const volcl::UsageError& e) {
        std::cerr << "volcl: " << volcl::printableMessage(e.what()) << '\n';
        return 2;
    } catch (const volcl::Error& e) {
        std::cerr << "volcl: " << volcl::printableMessage(e.what()) << '\n';
        return 1;
    } catch (const std::bad_alloc&) {
        std::cerr << "volcl: out of memory\n";
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "volcl: internal error: " << volcl::printableMessage(e.what()) << '\n';
        return 1;
    }
    return 0;
}
