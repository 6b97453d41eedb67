// Entry point of the volcl executable: parses the command line and turns exceptions into exit codes.
#include "apps/cli/Commands.hpp"
#include "core/Error.hpp"
#include "core/PrintableMessage.hpp"
#include "core/Version.hpp"
#if defined(VOLCL_WITH_BENCH)
#include "apps/bench/BenchCommand.hpp"
#endif

#include <csignal>
#include <iostream>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <string>
#include <string_view>

namespace {

/// The first word that is not an option (or the value of --device) names a subcommand: refuse an unknown
/// one by name before CLI11 reports something vaguer. Descends into a group such as `bench`.
void checkSubcommandNames(const CLI::App& app, int argc, char** argv) {
    const CLI::App* level = &app;
    for (int i = 1; i < argc; ++i) {
        const std::string_view arg = argv[i];
        if (arg == "--") return;
        if (arg == "--device") {
            ++i;
            continue;
        }
        if (!arg.empty() && arg[0] == '-') continue;
        const CLI::App* sub = nullptr;
        for (const CLI::App* s : level->get_subcommands({}))
            if (s->get_name() == arg) sub = s;
        if (!sub) {
            std::string names;
            for (const CLI::App* s : level->get_subcommands({}))
                names += (names.empty() ? "" : ", ") + s->get_name();
            const std::string where = level == &app ? "" : " of '" + level->get_name() + "'";
            throw volcl::UsageError("unknown subcommand '" + std::string(arg) + "'" + where +
                                    " (expected one of: " + names + ")");
        }
        if (sub->get_subcommands({}).empty()) return; // its own arguments follow
        level = sub;
    }
}

} // namespace

int main(int argc, char** argv) {
    // Over a file size limit (ulimit -f) a write then fails with EFBIG and ends in a clean IoError, instead
    // of SIGXFSZ killing the process before it can report anything.
    std::signal(SIGXFSZ, SIG_IGN);
#if defined(__GLIBC__)
    // Freed blocks stay with the process instead of going back to the system: per-brick temporaries of a
    // megabyte or more were unmapped and faulted in again for every brick (173,000 page faults in a one-shot
    // lossless encode of a 35 MB volume, 22,000 with these settings), and fresh pages are slow to touch on
    // virtual machines. Blocks over 32 MB (volumes) are still mapped and unmapped on their own.
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
    mallopt(M_TRIM_THRESHOLD, 512 << 20);
#endif
    CLI::App app{"volcl: OpenCL volume processing (codec, pre-integration, ray marching)", "volcl"};
    app.require_subcommand(1);
    volcl::cli::GlobalOptions global;
    app.add_option("--device", global.device,
                   "OpenCL device: index or name substring (default $VOLCL_DEVICE)");
    app.add_flag("-q,--quiet", global.quiet, "No progress output");
    app.set_version_flag("--version", std::string(volcl::version()), "Print the version and exit");
#if defined(VOLCL_WITH_BENCH)
    // First, so --help lists it where it always stood; without the module `volcl bench` is an unknown
    // subcommand (exit 2).
    volcl::cli::addBenchCommand(app, global);
#endif

    volcl::cli::addInfoCommands(app, global);
    volcl::cli::addDemoCommand(app, global);
    volcl::cli::addGenerateCommand(app, global);
    volcl::cli::addViewCommand(app, global);
    volcl::cli::addPreintCommands(app, global);
    volcl::cli::addRenderCommands(app, global);
    volcl::cli::addCodecCommands(app, global);
    volcl::cli::addHelpExamples(app);

    // The single place where errors become messages and exit codes: usage errors exit 2, runtime errors 1,
    // each with one line on stderr.
    try {
        checkSubcommandNames(app, argc, argv);
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
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
