// Rendering with several MPI ranks (issue 48; integrators/distributed/cluster.h): `mpirun -n N
// render ...` writes the image of `render ...` alone, bit for bit, for every integrator, with a
// regulariser, with --time (at the pass count the ranks reached), and across checkpoints written
// and resumed with other numbers of ranks. Built only with MPI (tests/CMakeLists.txt). The ranks
// are oversubscribed on the CI's two cores; as root, Open MPI needs its allow-run-as-root flag.
#include <catch2/catch.hpp>

#include <nlohmann/json.hpp>
#include <string>

#include "core/image.h"
#include "process.h"

using namespace lt;
using namespace lt::test;

namespace {

const std::string kRender = LT_RENDER_BIN;
const std::string kScene = std::string(LT_SOURCE_DIR) + "/scenes/cornell-box.xml";

// mpirun with N ranks (oversubscribed: more ranks than cores is the test's point, not a mistake).
std::string mpirun(int ranks) {
    return std::string(LT_MPIEXEC) + " --allow-run-as-root --oversubscribe -n " + std::to_string(ranks) + " ";
}

// Whether two images are the same bit for bit (and how many pixels differ, for the message).
size_t differing(const Image& a, const Image& b) {
    if (a.width != b.width || a.height != b.height) return size_t(-1);
    size_t n = 0;
    for (size_t i = 0; i < a.pixels.size(); ++i) n += !(a.pixels[i] == b.pixels[i]);
    return n;
}

// Renders `args` alone (two threads) and with 1, 2 and 3 ranks (one thread each): the same image.
void checkSameWithRanks(const TempDir& dir, const std::string& args) {
    const std::string alone = dir.file("alone.exr");
    const Run r0 = sh(kRender + " " + args + " --threads 2 -q -o " + alone);
    INFO(args << "\n" << r0.output);
    REQUIRE(r0.code == 0);
    const Image ref = readImage(alone);
    for (int n : {1, 2, 3}) {
        const std::string out = dir.file("ranks" + std::to_string(n) + ".exr");
        const Run r = sh(mpirun(n) + kRender + " " + args + " --threads 1 -q -o " + out);
        INFO(n << " ranks: " << r.output);
        REQUIRE(r.code == 0);
        CHECK(differing(readImage(out), ref) == 0);
    }
}

}  // namespace

TEST_CASE("MPI: every integrator renders the single-process image bit for bit with 1 2 and 3 ranks", "[mpi]") {
    TempDir dir("lt_test_mpi");
    for (const char* integrator : {"pt", "bpt", "vcm", "lt", "ppm"}) {
        INFO(integrator);
        checkSameWithRanks(dir, kScene + " -D res=24 --spp 7 --seed 3 --integrator " + std::string(integrator));
    }
}

TEST_CASE("MPI: regularised renders are the single-process image bit for bit", "[mpi]") {
    // JG19's consistent bound, KD13's radius and OPSR's offset depend on the pass index only.
    TempDir dir("lt_test_mpi_reg");
    const std::string glass = std::string(LT_SOURCE_DIR) + "/scenes/cornell-box-point-in-glass.xml -D res=24 --spp 5";
    checkSameWithRanks(dir, glass + " --integrator pt --reg jg19");
    checkSameWithRanks(dir, glass + " --integrator vcm --reg jg19");
    checkSameWithRanks(dir, glass + " --integrator bpt --reg kd13");
    checkSameWithRanks(dir, glass + " --integrator pt --reg opsr --reg-opsr-consistent");
}

TEST_CASE("MPI: a --time render is the single-process image of the passes the ranks reached", "[mpi]") {
    TempDir dir("lt_test_mpi_time");
    const std::string out = dir.file("timed.exr"), stats = dir.file("timed.json");
    const Run r = sh(mpirun(3) + kRender + " " + kScene + " -D res=24 --integrator bpt --time 1.5 --threads 1 -q -o " +
                     out + " --stats-json " + stats);
    INFO(r.output);
    REQUIRE(r.code == 0);
    const nlohmann::json j = nlohmann::json::parse(readText(stats));
    const uint64_t spp = j["spp"];
    INFO("spp reached: " << spp);
    REQUIRE(spp > 3);
    // Every pass handed out was rendered by one rank: the ranks' counts add up to the passes.
    REQUIRE(j["mpi_ranks"] == 3);
    uint64_t sum = 0;
    for (const auto& n : j["mpi_passes_per_rank"]) sum += n.get<uint64_t>();
    CHECK(sum == spp);
    const std::string alone = dir.file("alone.exr");
    REQUIRE(sh(kRender + " " + kScene + " -D res=24 --integrator bpt -q --spp " + std::to_string(spp) + " -o " + alone)
                .code == 0);
    CHECK(differing(readImage(out), readImage(alone)) == 0);
}

TEST_CASE("MPI: a checkpoint written by 3 ranks resumes with 1 and with 2 to the straight image", "[mpi][checkpoint]") {
    TempDir dir("lt_test_mpi_resume");
    const std::string args = kScene + " -D res=24 --integrator vcm --seed 9 -q";
    const std::string straight = dir.file("straight.exr"), ckpt = dir.file("c.ckpt");
    REQUIRE(sh(kRender + " " + args + " --spp 10 -o " + straight).code == 0);
    const Run first = sh(mpirun(3) + kRender + " " + args + " --spp 4 --threads 1 --checkpoint " + ckpt + " -o " +
                         dir.file("first.exr"));
    INFO(first.output);
    REQUIRE(first.code == 0);
    for (int n : {1, 2}) {
        const std::string out = dir.file("resumed" + std::to_string(n) + ".exr");
        const std::string launch = n == 1 ? std::string() : mpirun(n);
        const Run r = sh(launch + kRender + " " + args + " --spp 10 --threads 1 --resume " + ckpt + " -o " + out);
        INFO(n << " ranks: " << r.output);
        REQUIRE(r.code == 0);
        CHECK(differing(readImage(out), readImage(straight)) == 0);
    }
    // Periodic checkpoints while 2 ranks render (every pass closes a segment): the same image.
    const std::string periodic = dir.file("periodic.exr");
    const Run p = sh(mpirun(2) + kRender + " " + args + " --spp 10 --threads 1 --checkpoint " + dir.file("p.ckpt") +
                     " --checkpoint-every 0.001 -o " + periodic);
    INFO(p.output);
    REQUIRE(p.code == 0);
    CHECK(differing(readImage(periodic), readImage(straight)) == 0);
}

namespace {

// Starts `mpirun -n 2 render ... --checkpoint C --checkpoint-every 0.2` in the background, waits
// until the checkpoint exists (at most 60 s), then runs `action` (a shell command; $PID_ROOT and
// $PID_RANK1 are the ranks' processes) and waits for mpirun. Returns mpirun's exit code.
int interruptedRun(const TempDir& dir, const std::string& args, const std::string& action) {
    const std::string script = dir.write("run.sh", "#!/bin/bash\n"
        "cd " + dir.dir.string() + "\n" +
        mpirun(2) + kRender + " " + args + " --threads 1 -q --checkpoint c.ckpt --checkpoint-every 0.2 -o out.exr "
        "> log.txt 2>&1 &\n"
        "MPIRUN=$!\n"
        "for i in $(seq 600); do [ -f c.ckpt ] && break; sleep 0.1; done\n"
        "sleep 0.5\n"
        "for p in $(pgrep -f 'render .*--checkpoint c.ckpt'); do\n"
        "  r=$(tr '\\0' '\\n' < /proc/$p/environ 2>/dev/null | sed -n 's/^OMPI_COMM_WORLD_RANK=//p')\n"
        "  [ \"$r\" = 0 ] && PID_ROOT=$p\n"
        "  [ \"$r\" = 1 ] && PID_RANK1=$p\n"
        "done\n" +
        action + "\n"
        "wait $MPIRUN\n"
        "exit $?\n");
    return sh("bash " + script).code;
}

}  // namespace

TEST_CASE("MPI: SIGINT to mpirun writes the image of the passes done, and a killed rank writes nothing", "[mpi][checkpoint]") {
    const std::string args = kScene + " -D res=32 --integrator pt --spp 1000000";
    SECTION("SIGINT: every rank stops after its pass; rank 0 writes the single-process image of P passes") {
        TempDir dir("lt_test_mpi_int");
        interruptedRun(dir, args, "kill -INT $MPIRUN");
        INFO(readText(dir.file("log.txt")));
        REQUIRE(std::filesystem::exists(dir.file("out.exr")));
        const std::string log = readText(dir.file("log.txt"));
        const size_t at = log.find("holds ");
        REQUIRE(at != std::string::npos);
        const uint64_t spp = std::stoull(log.substr(at + 6));
        REQUIRE(spp > 0);
        const std::string alone = dir.file("alone.exr");
        REQUIRE(sh(kRender + " " + kScene + " -D res=32 --integrator pt -q --spp " + std::to_string(spp) + " -o " + alone)
                    .code == 0);
        CHECK(differing(readImage(dir.file("out.exr")), readImage(alone)) == 0);
    }
    SECTION("a rank killed: mpirun fails, no image is written, the last checkpoint resumes alone") {
        TempDir dir("lt_test_mpi_kill");
        const int code = interruptedRun(dir, args, "kill -9 $PID_RANK1");
        INFO(readText(dir.file("log.txt")));
        CHECK(code != 0);
        CHECK_FALSE(std::filesystem::exists(dir.file("out.exr")));
        const std::string header = readText(dir.file("c.ckpt")).substr(0, 200);
        const size_t at = header.find("passes ");
        REQUIRE(at != std::string::npos);
        const uint64_t saved = std::stoull(header.substr(at + 7));
        const std::string more = std::to_string(saved + 3);
        const std::string resumed = dir.file("resumed.exr"), straight = dir.file("straight.exr");
        const std::string same = kScene + " -D res=32 --integrator pt -q --spp " + more;
        REQUIRE(sh(kRender + " " + same + " --resume " + dir.file("c.ckpt") + " -o " + resumed).code == 0);
        REQUIRE(sh(kRender + " " + same + " -o " + straight).code == 0);
        CHECK(differing(readImage(resumed), readImage(straight)) == 0);
    }
}

TEST_CASE("MPI: reference renders its chunks with every rank, the image of one process", "[mpi]") {
    TempDir dir("lt_test_mpi_ref");
    const std::string ref = std::string(LT_TOOLS_DIR) + "/reference " + kScene +
                            " -D res=24 --spp 12 --chunks 3 -c vcm --threads 1 -o ";
    REQUIRE(sh(ref + dir.file("alone.exr")).code == 0);
    const Run r = sh(mpirun(3) + ref + dir.file("ranks.exr"));
    INFO(r.output);
    REQUIRE(r.code == 0);
    CHECK(differing(readImage(dir.file("ranks.exr")), readImage(dir.file("alone.exr"))) == 0);
    // Run again: rank 0 finds it up to date, and every rank returns without rendering.
    const Run again = sh(mpirun(2) + ref + dir.file("ranks.exr"));
    CHECK(again.code == 0);
    CHECK(again.output.find("up to date") != std::string::npos);
}
