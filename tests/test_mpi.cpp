// Rendering with several MPI ranks (issue 48; integrators/distributed/cluster.h): `mpirun -n N
// render ...` writes the image of `render ...` alone, bit for bit, for every integrator, with a
// regulariser, with --time (at the pass count the ranks reached), and across checkpoints written
// and resumed with other numbers of ranks. Built only with MPI (tests/CMakeLists.txt). The ranks
// are oversubscribed on the CI's two cores; as root, Open MPI needs its allow-run-as-root flag.
#include <catch2/catch.hpp>

#include <nlohmann/json.hpp>
#include <filesystem>
#include <string>
#include <vector>

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

// Starts `mpirun -n N render ... --checkpoint C --checkpoint-every 0.2` in the background, waits
// until the checkpoint exists (at most 60 s) and `wait` seconds more, then runs `action` (a shell
// command; $PID_ROOT and $PID_RANK1 are the ranks' processes) and waits for mpirun. Returns
// mpirun's exit code.
int interruptedRun(const TempDir& dir, const std::string& args, const std::string& action, int ranks = 2,
                   double wait = 0.5) {
    const std::string script = dir.write("run.sh", "#!/bin/bash\n"
        "cd " + dir.dir.string() + "\n" +
        mpirun(ranks) + kRender + " " + args + " --threads 1 -q --checkpoint c.ckpt --checkpoint-every 0.2 -o out.exr "
        "> log.txt 2>&1 &\n"
        "MPIRUN=$!\n"
        "for i in $(seq 600); do [ -f c.ckpt ] && break; sleep 0.1; done\n"
        "sleep " + std::to_string(wait) + "\n"
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

// The passes a checkpoint file holds (its header's "passes N").
uint64_t checkpointPasses(const std::string& file) {
    const std::string header = readText(file).substr(0, 200);
    const size_t at = header.find("passes ");
    REQUIRE(at != std::string::npos);
    return std::stoull(header.substr(at + 7));
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
        const uint64_t saved = checkpointPasses(dir.file("c.ckpt"));
        const std::string more = std::to_string(saved + 3);
        const std::string resumed = dir.file("resumed.exr"), straight = dir.file("straight.exr");
        const std::string same = kScene + " -D res=32 --integrator pt -q --spp " + more;
        REQUIRE(sh(kRender + " " + same + " --resume " + dir.file("c.ckpt") + " -o " + resumed).code == 0);
        REQUIRE(sh(kRender + " " + same + " -o " + straight).code == 0);
        CHECK(differing(readImage(resumed), readImage(straight)) == 0);
    }
}


namespace {

// Guided PT whose tree splits space many times (a low spatial threshold) on a small image.
const std::string kGuided = kScene + " -D res=24 --integrator pt --guiding-spatial-threshold 20";

}  // namespace

TEST_CASE("MPI: guided renders are the single-process image bit for bit with 1 2 and 3 ranks", "[mpi][guiding]") {
    // Every rank builds the single process's SD-tree (trainer.h, "Several ranks"): the image
    // depends on every tree and pixel estimate of the training, so one record, sum or iteration
    // decision out of place changes it. 64 spp train 31 passes in 5 iterations; the last one
    // (16 passes) shares its records in segments of 4 passes a rank.
    TempDir dir("lt_test_mpi_guided");
    checkSameWithRanks(dir, kGuided + " --spp 64 --seed 5 --guiding variance");
    checkSameWithRanks(dir, kGuided + " --spp 64 --seed 6 --guiding variance --guiding-bsdf-fraction learned");
    checkSameWithRanks(dir, kGuided + " --spp 40 --seed 7 --guiding radiance --guiding-bsdf-fraction learned");
    // Periodic checkpoints (a segment ends at nearly every pass, inside iterations and at their ends).
    const std::string alone = dir.file("alone.exr");
    const std::string args = kGuided + " --spp 40 --seed 8 --guiding variance --guiding-bsdf-fraction learned -q";
    REQUIRE(sh(kRender + " " + args + " -o " + alone).code == 0);
    for (int n : {2, 3}) {
        const std::string out = dir.file("periodic" + std::to_string(n) + ".exr");
        const Run r = sh(mpirun(n) + kRender + " " + args + " --threads 1 --checkpoint " + dir.file("p.ckpt") +
                         " --checkpoint-every 0.001 -o " + out);
        INFO(n << " ranks: " << r.output);
        REQUIRE(r.code == 0);
        CHECK(differing(readImage(out), readImage(alone)) == 0);
        CHECK(checkpointPasses(dir.file("p.ckpt")) == 40);
    }
}

TEST_CASE("MPI: a guided render stopped by SIGINT on 3 ranks resumes with 1 and with 2 to the straight image",
          "[mpi][guiding][checkpoint]") {
    // The checkpoint holds rank 0's trainer state: every rank's records applied and sums added.
    // (2000 spp train 1023 passes: the signal, sent to rank 0 once the first checkpoint exists,
    // most likely stops the render inside a training iteration; mpirun passes a signal on about a
    // second late. Any stop must resume to the straight image.)
    TempDir dir("lt_test_mpi_guided_int");
    const std::string args = kGuided + " -D res=16 --spp 2000 --seed 4 --guiding variance --guiding-bsdf-fraction learned";
    interruptedRun(dir, args, "kill -INT $PID_ROOT", 3, 0.0);
    INFO(readText(dir.file("log.txt")));
    REQUIRE(std::filesystem::exists(dir.file("c.ckpt")));
    const uint64_t saved = checkpointPasses(dir.file("c.ckpt"));
    INFO("stopped at " << saved << " passes");
    REQUIRE(saved < 2000);
    const std::string straight = dir.file("straight.exr");
    REQUIRE(sh(kRender + " " + args + " -q -o " + straight).code == 0);
    for (int n : {1, 2}) {
        const std::string out = dir.file("resumed" + std::to_string(n) + ".exr");
        const std::string launch = n == 1 ? std::string() : mpirun(n);
        const Run r = sh(launch + kRender + " " + args + " -q --threads 1 --resume " + dir.file("c.ckpt") + " -o " + out);
        INFO(n << " ranks: " << r.output);
        REQUIRE(r.code == 0);
        CHECK(differing(readImage(out), readImage(straight)) == 0);
    }
}

// The passes guided PT trains with a budget of `spp` passes (Trainer: iteration k, 2^k passes,
// trains while it would end within the first half of the budget).
uint64_t trainingPassesFor(uint64_t spp) {
    if (spp < 2) return 0;
    uint64_t end = 1;  // iteration 0 (one pass) trains
    for (int k = 1; 2 * (end + (uint64_t(1) << k)) <= spp; ++k) end += uint64_t(1) << k;
    return end;
}

TEST_CASE("MPI: a guided --time render follows rank 0's schedule on every rank", "[mpi][guiding]") {
    // With --time, rank 0's clock decides whether the next iteration trains, and every rank must
    // follow it: ranks that part ways wait for each other (the test's time limit fails them) or
    // hold other trees (the ranks compare their trees' hashes at every iteration's end: an error).
    // Where rank 0 chose the schedule --spp P would (both train while the next iteration ends
    // within half the budget, in seconds or in passes), the image is the single process's with
    // --spp P bit for bit. The clock often stops training an iteration earlier (its iterations
    // cost more than the final one's passes): such a render has no single-process twin, and the
    // next limit is tried.
    TempDir dir("lt_test_mpi_guided_time");
    const std::string args = kGuided + " --guiding variance --seed 2 -q";
    int compared = 0;
    for (const char* limit : {"0.04", "0.06", "0.08", "0.12", "0.16"}) {
        const std::string out = dir.file("timed.exr"), stats = dir.file("timed.json");
        const Run r = sh(mpirun(2) + kRender + " " + args + " --time " + limit + " --threads 1 -o " + out +
                         " --stats-json " + stats);
        INFO(r.output);
        REQUIRE(r.code == 0);
        const nlohmann::json j = nlohmann::json::parse(readText(stats));
        const uint64_t spp = j["spp"], training = j["guiding_training_spp"];
        const int iterations = j["guiding_iterations"];
        INFO("--time " << limit << ": " << spp << " spp, " << training << " training in " << iterations << " iterations");
        REQUIRE(spp > 3);
        uint64_t sum = 0;
        for (const auto& n : j["mpi_passes_per_rank"]) sum += n.get<uint64_t>();
        CHECK(sum == spp);
        CHECK(training == (uint64_t(1) << (iterations - 1)) - 1);  // (the iterations before the last: 1, 2, 4, ...)
        if (training != trainingPassesFor(spp)) continue;
        const std::string alone = dir.file("alone.exr");
        REQUIRE(sh(kRender + " " + args + " --spp " + std::to_string(spp) + " -o " + alone).code == 0);
        CHECK(differing(readImage(out), readImage(alone)) == 0);
        ++compared;
    }
    if (compared == 0) WARN("every --time render chose a schedule --spp would not: no image compared");
}

TEST_CASE("MPI: strategy images are the single process's bit for bit with 2 and 3 ranks", "[mpi]") {
    // Every rank's per-technique sums are added on rank 0, which writes them; the sums are exact,
    // so the files are those of one process (of two threads here: the thread count does not
    // matter either).
    TempDir dir("lt_test_mpi_strategies");
    const std::string glass = std::string(LT_SOURCE_DIR) + "/scenes/cornell-box-point-in-glass.xml -D res=24 --spp 6 -q";
    for (const char* integrator : {"pt", "vcm"}) {
        const std::string args = glass + " --integrator " + integrator + " --reg jg19";
        const std::string alone = dir.file(std::string("alone_") + integrator);
        REQUIRE(sh(kRender + " " + args + " --threads 2 --strategy-images " + alone + " -o " + dir.file("a.exr")).code == 0);
        std::vector<std::string> names;
        for (const auto& e : std::filesystem::directory_iterator(alone)) names.push_back(e.path().filename().string());
        INFO(integrator << ": " << names.size() << " images");
        REQUIRE(names.size() > 5);  // (techniques s, t and merges, and regularised.exr)
        for (int n : {2, 3}) {
            const std::string ranks = dir.file(std::string("ranks_") + integrator + std::to_string(n));
            const Run r = sh(mpirun(n) + kRender + " " + args + " --threads 1 --strategy-images " + ranks + " -o " +
                             dir.file("r.exr"));
            INFO(n << " ranks: " << r.output);
            REQUIRE(r.code == 0);
            size_t files = 0;
            for (const auto& e : std::filesystem::directory_iterator(ranks)) ++files, (void)e;
            CHECK(files == names.size());
            for (const std::string& name : names) {
                INFO(name);
                CHECK(differing(readImage(ranks + "/" + name), readImage(alone + "/" + name)) == 0);
            }
        }
    }
}

TEST_CASE("MPI: a rank on a busy core renders fewer passes and the image stays the same", "[mpi]") {
    // Uneven machines: rank 0 on core 0, rank 1 on core 1 at nice 19 beside a busy loop at nice
    // 0 (the scheduler gives it about 1.5% of that core). Passes are handed out on demand, so
    // rank 0 should render nearly all of them; a static split would give 100/100. The threshold
    // 1.3 holds under other load on the machine: two more busy loops beside rank 0 still leave it
    // a third of its core, some twenty times rank 1's share. The image: the single process's, bit
    // for bit. (Guided renders split unevenly in the tests above; here a training segment would
    // wait for rank 1's pass.)
    TempDir dir("lt_test_mpi_uneven");
    const std::string args = kScene + " -D res=64 --spp 200 --seed 1";
    const std::string alone = dir.file("alone.exr"), out = dir.file("uneven.exr"), stats = dir.file("uneven.json");
    REQUIRE(sh(kRender + " " + args + " -q -o " + alone).code == 0);
    const std::string rank = kRender + " " + args + " --threads 1 -q -o " + out + " --stats-json " + stats;
    const std::string script = dir.write("uneven.sh", "#!/bin/bash\n"
        "taskset -c 1 bash -c 'while :; do :; done' &\n"
        "HOG=$!\n"
        "trap 'kill $HOG' EXIT\n" +
        std::string(LT_MPIEXEC) + " --allow-run-as-root --oversubscribe --bind-to none -n 1 taskset -c 0 " + rank +
        " : -n 1 taskset -c 1 nice -n 19 " + rank + "\n");
    const Run r = sh("bash " + script);
    INFO(args << "\n" << r.output);
    REQUIRE(r.code == 0);
    CHECK(differing(readImage(out), readImage(alone)) == 0);
    const nlohmann::json j = nlohmann::json::parse(readText(stats));
    const uint64_t fast = j["mpi_passes_per_rank"][0], slow = j["mpi_passes_per_rank"][1];
    INFO("passes: " << fast << " on the free core, " << slow << " on the busy one");
    CHECK(double(fast) >= 1.3 * double(slow));
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
