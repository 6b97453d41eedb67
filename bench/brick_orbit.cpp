// volcl-bench-brick-orbit: a camera orbiting a .vcz rendered from its bricks in one process, so the brick
// pool carries over between frames: per frame the working set, cache hits and misses, the hit rate, the
// frame time and the process's peak RSS, as CSV on stdout.
// Usage: volcl-bench-brick-orbit FILE.vcz TF.json [--frames 36] [--size 512] [--cache-mb 64]
//        [--lod full|auto] [--lod-error 0.01] [--elevation 20] [--turns 1]
#include "core/AtomicFile.hpp"
#include "core/runtime/PeakMemory.hpp"
#include "core/runtime/Timing.hpp"
#include "host/tf/TransferFunction.hpp"
#include "render/CameraFraming.hpp"
#include "render/bricks/BrickRenderer.hpp"
#include "wavelet/Codec.hpp"

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <string>

using namespace volcl;

int main(int argc, char** argv) {
    try {
        if (argc < 3) {
            std::fprintf(stderr,
                         "usage: %s FILE.vcz TF.json [--frames N] [--size PX] [--cache-mb MB] "
                         "[--lod full|auto] [--lod-error E] [--elevation DEG] [--turns T]\n",
                         argv[0]);
            return 1;
        }
        const std::string file = argv[1], tfFile = argv[2];
        int frames = 36, size = 512;
        double cacheMb = 64, lodError = 0.01, elevation = 20, turns = 1;
        std::string lod = "full";
        for (int i = 3; i + 1 < argc; i += 2) {
            const std::string k = argv[i], v = argv[i + 1];
            if (k == "--frames")
                frames = std::stoi(v);
            else if (k == "--size")
                size = std::stoi(v);
            else if (k == "--cache-mb")
                cacheMb = std::stod(v);
            else if (k == "--lod")
                lod = v;
            else if (k == "--lod-error")
                lodError = std::stod(v);
            else if (k == "--elevation")
                elevation = std::stod(v);
            else if (k == "--turns")
                turns = std::stod(v);
            else
                throw std::runtime_error("unknown option " + k);
        }
        ComputeContext cc;
        auto reader = std::make_shared<const VczReader>(readFileBytes(file), file);
        const TransferFunction tf = TransferFunction::fromFile(tfFile);
        Scene scene;
        scene.width = scene.height = size;
        scene.lod = lod == "auto" ? LodMode::Auto : LodMode::Full;
        scene.lodError = lodError;
        scene.cacheMb = cacheMb;
        BrickRenderer r(cc, reader, 0, tf, scene);
        std::printf("frame,azimuth,frame_ms,kernel_ms,visited,hidden,decoded,hits,hit_rate,voxels_decoded,"
                    "peak_pool_mb,peak_rss_mb,repacks,moved\n");
        for (int f = 0; f < frames; ++f) {
            const double az = 360.0 * turns * f / frames;
            const Camera cam =
                frameBox(r.bounds(), orbitDirection(az, elevation), Projection::Perspective, 30.0, 1.0);
            Stopwatch sw;
            r.setView(cam, size, size, scene.step);
            (void)r.render();
            const double ms = sw.milliseconds();
            const BrickStats& s = r.lastStats();
            const double rate = s.visited ? double(s.hits) / double(s.visited) : 1.0;
            std::printf("%d,%.1f,%.1f,%.1f,%zu,%zu,%zu,%zu,%.3f,%zu,%.1f,%.1f,%zu,%zu\n", f, az, ms,
                        r.lastKernelMilliseconds(), s.visited, s.hidden, s.decoded, s.hits, rate,
                        s.voxelsDecoded, double(s.peakPoolBytes) / 1048576.0,
                        double(peakResidentBytes()) / 1048576.0, s.repacks, s.moved);
            std::fflush(stdout);
        }
        return 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "volcl-bench-brick-orbit: %s\n", e.what());
        return 1;
    }
}
