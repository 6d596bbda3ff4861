// The render CLI end to end: a good render writes finite EXR + PNG and statistics; every bad
// scene in tests/data/bad gives a clear error (file, line, the expected words), exit code != 0,
// writes no output and does not crash; bad command lines exit with 1.
#include <catch2/catch.hpp>
#include "process.h"
#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <nlohmann/json.hpp>
#include <sys/wait.h>
#include "core/image.h"
#include "tools/analysis.h"

namespace fs = std::filesystem;
using lt::test::Run;
using lt::test::sh;

namespace {

Run run(const std::string& args) { return sh(std::string(LT_RENDER_BIN) + " " + args); }

// Whether two image files hold the same pixels, bit for bit (a resumed render against one run
// straight through).
bool samePixels(const fs::path& a, const fs::path& b) {
    const lt::Image ia = lt::readImage(a.string()), ib = lt::readImage(b.string());
    return ia.pixels.size() == ib.pixels.size() && std::equal(ia.pixels.begin(), ia.pixels.end(), ib.pixels.begin());
}

fs::path tempDir(const std::string& name) { return lt::test::tempDir("lt_cli", name); }

}  // namespace

TEST_CASE("render writes a finite EXR, a PNG and statistics for the default scene", "[cli]") {
    fs::path dir = tempDir("good");
    fs::path out = dir / "cb.exr", stats = dir / "stats.json";
    Run r = run(std::string(LT_SOURCE_DIR) + "/scenes/cornell-box.xml -D res=24 --spp 2 --quiet -o " + out.string() +
                " --stats-json " + stats.string());
    INFO(r.output);
    REQUIRE(r.code == 0);
    REQUIRE(fs::exists(out));
    CHECK(fs::file_size(dir / "cb.png") > 0);
    lt::Image img = lt::readImage(out.string());
    CHECK(img.width == 24);
    CHECK(img.height == 24);
    double sum = 0;
    for (const auto& c : img.pixels) {
        REQUIRE(lt::isFinite(c));
        sum += c.x + c.y + c.z;
    }
    CHECK(sum > 0);
    std::ifstream f(stats);
    std::string json((std::istreambuf_iterator<char>(f)), {});
    for (const char* key : {"\"spp\": 2", "\"seconds\"", "\"samples_per_second\"", "\"rays_per_second\"",
                            "\"invalid_samples\": 0"})
        CHECK(json.find(key) != std::string::npos);
    // The closing summary line.
    CHECK(std::regex_search(r.output, std::regex(R"(2 spp, [0-9.]+ s, .*samples/s, .*rays/s, 0 invalid samples)")));
}

TEST_CASE("every bad scene gives a clear error naming file and line, exit != 0, no output", "[cli][loader]") {
    fs::path dir = tempDir("bad");
    int files = 0;
    for (const auto& entry : fs::directory_iterator(fs::path(LT_SOURCE_DIR) / "tests/data/bad")) {
        if (entry.path().extension() != ".xml") continue;
        ++files;
        std::ifstream f(entry.path());
        std::string text((std::istreambuf_iterator<char>(f)), {});
        std::smatch m;
        REQUIRE(std::regex_search(text, m, std::regex(R"(expect-line:\s*(\d+))")));
        std::string line = m[1];
        REQUIRE(std::regex_search(text, m, std::regex(R"(expect:\s*([^\n]*?)\s*(-->|\n))")));
        std::string words = m[1];
        fs::path out = dir / (entry.path().stem().string() + ".exr");
        Run r = run(entry.path().string() + " --spp 1 --quiet -o " + out.string());
        INFO(entry.path().filename().string() << ": exit " << r.code << "\n" << r.output);
        CHECK(r.code == 2);
        CHECK(r.output.find(entry.path().filename().string() + ":" + line) != std::string::npos);
        size_t pos = 0;
        while (pos < words.size()) {
            size_t semi = words.find(';', pos);
            std::string w = words.substr(pos, semi == std::string::npos ? std::string::npos : semi - pos);
            w = std::regex_replace(w, std::regex(R"(^\s+|\s+$)"), "");
            if (!w.empty()) CHECK(r.output.find(w) != std::string::npos);
            if (semi == std::string::npos) break;
            pos = semi + 1;
        }
        CHECK_FALSE(fs::exists(out));
        CHECK_FALSE(fs::exists(dir / (entry.path().stem().string() + ".png")));
    }
    CHECK(files >= 20);
}

TEST_CASE("bad command lines exit with 1 and name the problem, numeric ranges in words", "[cli]") {
    std::string scene = std::string(LT_SOURCE_DIR) + "/scenes/cornell-box.xml --quiet -o /tmp/lt_cli_never.exr ";
    struct Case { std::string args, words; };
    for (const Case& c : {Case{"--spp -3", "--spp: must be greater than 0 (got -3)"}, Case{"--spp 2 --time 1", "excludes"},
                          Case{"--integrator nope", "nope"}, Case{"--no-such-flag", "no-such-flag"},
                          Case{"-D novalue", "name=value"}, Case{"--max-depth 1000", "max-depth"},
                          Case{"--reg jg19 --reg-quality off --reg-diffusion on", "diffusion heuristic"},
                          Case{"--reg jg19 --reg-diffusion maybe", "reg-diffusion"},
                          Case{"--reg kd13 --reg-lambda 0.6", "reg-lambda"}, Case{"--reg kd13 --reg-r0 -1", "reg-r0"},
                          Case{"--reg kd13 --reg-tau 50", "applies to --reg jg19 only"},
                          Case{"--reg jg19 --reg-r0 0.1", "applies to --reg kd13 only"},
                          Case{"--reg kd13 --integrator pt --pt-strategy nee", "needs --pt-strategy mis or bsdf"},
                          Case{"--reg opsr --reg-opsr-gamma 2", "reg-opsr-gamma"},
                          Case{"--reg kd13 --reg-opsr-gamma 0.1", "applies to --reg opsr only"},
                          Case{"--reg opsr --reg-opsr-table /no/such/opsr.json:low", "/no/such/opsr.json"},
                          Case{"--reg opsr --reg-opsr-gamma 0.1 --reg-opsr-table x.json", "either"},
                          Case{"--reg opsr --integrator ppm", "ppm makes no connections"},
                          Case{"--reg opsr --reg-lambda 0.2", "needs --reg-opsr-consistent"},
                          Case{"--reg opsr --integrator pt --pt-strategy nee", "needs --pt-strategy mis or bsdf"},
                          Case{"--reg jg19 --reg-opsr-always-sample", "applies to --reg opsr only"},
                          Case{"--reg opsr --integrator bpt --reg-opsr-always-sample", "--integrator pt only"},
                          Case{"--reg-tail-rr 0.1", "needs --reg jg19, kd13, opsr or jg19,opsr"},
                          Case{"--reg opsr --reg-tail-rr -1", "--reg-tail-rr: must be in [0, 1e+06] (got -1)"},
                          Case{"--reg jg19,opsr --reg-quality off", "bound and schedule only"},
                          Case{"--reg jg19,opsr --reg-specular cone", "bound and schedule only"},
                          Case{"--reg jg19,opsr --integrator ppm", "ppm makes no connections"},
                          Case{"--reg jg19,opsr --reg-tau 0.1", "reg-tau"},
                          Case{"--reg opsr,jg19", "opsr,jg19"},
                          Case{"--reg jg19 --reg-bound loose", "reg-bound"},
                          Case{"--reg jg19 --reg-energy some", "reg-energy"},
                          Case{"--reg kd13 --reg-bound published", "applies to --reg jg19 only"},
                          Case{"--reg opsr --reg-bound published", "applies to --reg jg19 only"},
                          Case{"--reg kd13 --reg-energy none", "--reg-energy applies to --reg jg19, opsr and jg19,opsr"},
                          // Numeric options state their range in words (CLI11's own checks printed the
                          // bounds as numbers, DBL_MAX in full for --spp -3).
                          Case{"--spp 0", "--spp: must be greater than 0 (got 0)"},
                          Case{"--spp x", "--spp: must be a number"},
                          Case{"--threads -1", "--threads: must be 0 or more (0 = all cores) (got -1)"},
                          Case{"--max-depth 65", "--max-depth: must be in [-1, 64] (-1 = unlimited) (got 65)"},
                          Case{"--radius-alpha 0", "--radius-alpha: must be in (0, 1] (got 0)"},
                          Case{"--reg-tau 0.1", "--reg-tau: must be greater than 1/(2 pi) = 0.159 (got 0.1)"},
                          Case{"--reg-lambda 0.5", "--reg-lambda: must be in [0, 0.5)"}}) {
        Run r = run(scene + c.args);
        INFO(c.args << "\n" << r.output);
        CHECK(r.code == 1);
        CHECK(r.output.find(c.words) != std::string::npos);
        CHECK(r.output.find("179769313486") == std::string::npos);  // (DBL_MAX written out)
    }
    Run missing = run("/no/such/scene.xml --quiet");
    CHECK(missing.code == 2);
    CHECK(missing.output.find("/no/such/scene.xml") != std::string::npos);
    CHECK_FALSE(fs::exists("/tmp/lt_cli_never.exr"));
}

TEST_CASE("the external public scenes render at low resolution", "[cli][external]") {
    fs::path dir = tempDir("external");
    fs::path ext = fs::path(LT_SOURCE_DIR) / "scenes/external";
    for (const char* s : {"bitterli-cornell-box/scene.xml", "bitterli-veach-mis/scene.xml", "mitsuba3-cbox/cbox-rgb.xml"}) {
        fs::path out = dir / (fs::path(s).parent_path().string() + ".exr");
        Run r = run((ext / s).string() + " -D resx=32 -D resy=24 -D res=32 --spp 4 --max-depth 4 --quiet -o " +
                    out.string());
        INFO(s << "\n" << r.output);
        REQUIRE(r.code == 0);
        lt::Image img = lt::readImage(out.string());
        double sum = 0;
        for (const auto& c : img.pixels) {
            REQUIRE(lt::isFinite(c));
            sum += c.x + c.y + c.z;
        }
        CHECK(sum / img.pixels.size() > 1e-3);  // lit, not black
    }
}

TEST_CASE("render with --strategy-images writes per-technique images that sum to the image", "[cli][bpt]") {
    // Every integrator: PT's emitter hits (s = 0) and next-event estimation (s = 1), BPT's and
    // VCM's connections with light tracing (t = 1), VCM's merges. Under JG19 also
    // regularised.exr, the part of the image whose own technique was regularised: on the glass
    // ball round a point light, PT's and BPT's light through the glass (JG19 regularises it and
    // nothing else reaches it with PT; a positive share), never more than the image; and
    // singular.exr, the part no unregularised technique can produce (the point light seen through
    // the glass, L S E and L S S E): positive there, never more than the regularised part (only a
    // regularised connection reaches it), absent without a regulariser and with an area light.
    fs::path dir = tempDir("strategies");
    struct Case {
        std::string integ, scene, extra;
    };
    const std::string box = std::string(LT_SOURCE_DIR) + "/scenes/cornell-box.xml",
                      glass = std::string(LT_SOURCE_DIR) + "/scenes/cornell-box-point-in-glass.xml";
    // (VCM: a radius at which 2 spp of 16 x 16 surely merge; the default merges a few times in
    // 8 spp: whether one happens in 2 depended on the seed's luck.)
    for (const Case& c : {Case{"pt", box, ""}, Case{"bpt", box, ""}, Case{"vcm", box, " --radius 0.05"},
                          Case{"pt", glass, " --reg jg19"}, Case{"bpt", glass, " --reg jg19"}}) {
        const bool reg = !c.extra.empty() && c.extra.find("jg19") != std::string::npos;
        const std::string tag = c.integ + (reg ? "-jg19" : "");
        fs::path out = dir / (tag + ".exr"), sdir = dir / tag;
        Run r = run(c.scene + " -D res=16 --spp 2 --max-depth 4 --quiet --integrator " + c.integ + " -o " + out.string() +
                    " --strategy-images " + sdir.string() + c.extra);
        INFO(tag << ": " << r.output);
        REQUIRE(r.code == 0);
        lt::Image img = lt::readImage(out.string());
        lt::Image sum(img.width, img.height);
        int files = 0;
        bool sawMerge = false, sawLightTracing = false, sawEmitterHit = false, sawNee = false, sawRegularised = false;
        double regularisedSum = 0.0, singularSum = 0.0;
        lt::Image regularisedImg;
        if (fs::exists(sdir / "regularised.exr")) regularisedImg = lt::readImage((sdir / "regularised.exr").string());
        for (const auto& e : fs::directory_iterator(sdir)) {
            lt::Image s = lt::readImage(e.path().string());
            const std::string name = e.path().filename().string();
            if (name == "singular.exr") {
                REQUIRE(regularisedImg.pixels.size() == s.pixels.size());
                for (size_t i = 0; i < s.pixels.size(); ++i)
                    for (int k = 0; k < 3; ++k) {
                        singularSum += s.pixels[i][k];
                        CHECK(s.pixels[i][k] <= regularisedImg.pixels[i][k] * (1.f + 1e-4f) + 1e-6f);
                    }
                continue;
            }
            if (name == "regularised.exr") {
                sawRegularised = true;
                for (size_t i = 0; i < s.pixels.size(); ++i)
                    for (int k = 0; k < 3; ++k) {
                        regularisedSum += s.pixels[i][k];
                        CHECK(s.pixels[i][k] <= img.pixels[i][k] * (1.f + 1e-4f) + 1e-6f);
                    }
                continue;
            }
            for (size_t i = 0; i < s.pixels.size(); ++i) sum.pixels[i] += s.pixels[i];
            ++files;
            sawMerge |= name.rfind("merge_", 0) == 0;
            sawLightTracing |= name.find("_t1.exr") != std::string::npos;
            sawEmitterHit |= name.rfind("s0_", 0) == 0;
            sawNee |= name.rfind("s1_", 0) == 0;
        }
        CHECK(files >= (c.integ == "pt" ? 3 : 6));  // (PT: next-event estimation at t = 2, 3, 4 at least)
        CHECK(sawLightTracing == (c.integ != "pt"));
        CHECK(sawMerge == (c.integ == "vcm"));
        CHECK(sawNee);
        if (c.scene == box) CHECK(sawEmitterHit);  // (the point light in the glass cannot be hit)
        CHECK(sawRegularised == reg);
        if (reg) CHECK(regularisedSum > 0.0);
        CHECK((singularSum > 0.0) == reg);  // (on the box with the area light there is no regulariser)
        CHECK(fs::exists(sdir / "singular.exr") == reg);
        for (size_t i = 0; i < img.pixels.size(); ++i)
            for (int k = 0; k < 3; ++k) CHECK(sum.pixels[i][k] == Approx(img.pixels[i][k]).epsilon(1e-4).margin(1e-6));
    }
}

TEST_CASE("the scene's integrator type selects the integrator and --integrator overrides it", "[cli][bpt]") {
    fs::path dir = tempDir("xmlinteg");
    Run r = run(std::string(LT_SOURCE_DIR) + "/tests/data/sds/sds.xml --spp 1 --quiet -o " + (dir / "a.exr").string());
    INFO(r.output);
    CHECK(r.code == 0);
    CHECK(r.output.rfind("vcm:", 0) == 0);  // sds.xml asks for vcm
    r = run(std::string(LT_SOURCE_DIR) + "/tests/data/sds/sds.xml --spp 1 --quiet --integrator ppm -o " + (dir / "b.exr").string());
    CHECK(r.output.rfind("ppm:", 0) == 0);
}

TEST_CASE("render with --time runs passes until the time is up", "[cli]") {
    fs::path dir = tempDir("time");
    fs::path stats = dir / "s.json";
    Run r = run(std::string(LT_SOURCE_DIR) + "/scenes/cornell-box.xml -D res=16 --time 0.5 --quiet -o " +
                (dir / "t.exr").string() + " --stats-json " + stats.string());
    INFO(r.output);
    REQUIRE(r.code == 0);
    std::ifstream f(stats);
    std::string json((std::istreambuf_iterator<char>(f)), {});
    std::smatch m;
    REQUIRE(std::regex_search(json, m, std::regex(R"re("spp": (\d+))re")));
    CHECK(std::stoi(m[1]) >= 2);  // a 16x16 pass takes well under a millisecond
    REQUIRE(std::regex_search(json, m, std::regex(R"re("seconds": ([0-9.e+-]+))re")));
    CHECK(std::stod(m[1]) >= 0.5);
    CHECK(std::stod(m[1]) < 5.0);
}

TEST_CASE("an output that cannot be written fails before the render, and a missing folder is created", "[cli]") {
    // A folder where a file is (the parent is a regular file), an output that is a folder, and a
    // statistics file that cannot be written: exit 3 at once, naming the file. The render asked for
    // (256^2, 100000 spp) would take minutes, so an exit within the test's time shows it was not
    // started. A missing nested folder is created and the image written there.
    fs::path dir = tempDir("unwritable");
    std::ofstream(dir / "file") << "x";
    fs::create_directories(dir / "folder.exr");
    const std::string scene = std::string(LT_SOURCE_DIR) + "/scenes/cornell-box.xml --quiet --spp 100000 ";
    for (const auto& [args, named] : std::vector<std::pair<std::string, std::string>>{
             {"-o " + (dir / "file/out.exr").string(), (dir / "file/out.exr").string()},
             {"-o " + (dir / "folder.exr").string(), "it is a folder"},
             {"-o " + (dir / "ok.exr").string() + " --stats-json " + (dir / "file/s.json").string(), (dir / "file/s.json").string()}}) {
        Run r = run(scene + args);
        INFO(args << "\n" << r.output);
        CHECK(r.code == 3);
        CHECK(r.output.find("cannot write '") != std::string::npos);
        CHECK(r.output.find(named) != std::string::npos);
    }
    CHECK_FALSE(fs::exists(dir / "ok.exr"));
    Run made = run(std::string(LT_SOURCE_DIR) + "/scenes/cornell-box.xml --quiet --spp 1 -D res=8 -o " +
                   (dir / "new/deeper/img.exr").string());
    INFO(made.output);
    CHECK(made.code == 0);
    CHECK(fs::exists(dir / "new/deeper/img.exr"));
    CHECK(fs::exists(dir / "new/deeper/img.png"));
    fs::remove_all(dir);
}

TEST_CASE("a write that fails for lack of space keeps the previous image whole and leaves no temporary file", "[cli][errors]") {
    // The disk fills up after the output probe: a 128 KiB filesystem holds the old 8^2 image
    // (about 1.4 KB) but not the new 256^2 one (about 600 KB). render exits 3 naming the file; the
    // old EXR and PNG are byte for byte what they were and nothing else is left in the folder.
    // Two ways of filling the disk, each a different errno for the writers:
    //  - a full tmpfs (ENOSPC), mounted in a user and mount namespace of its own (unshare -rm):
    //    where this machine does not allow that, this part says so and is skipped;
    //  - the process's file-size limit (ulimit -f, EFBIG; SIGXFSZ ignored), which any machine has.
    fs::path dir = tempDir("fullfs");
    const std::string render = std::string(LT_RENDER_BIN) + " " + LT_SOURCE_DIR + "/scenes/cornell-box.xml -q --spp 1 ";
    Run old = run(std::string(LT_SOURCE_DIR) + "/scenes/cornell-box.xml -q --spp 1 -D res=8 -o " + (dir / "old.exr").string());
    REQUIRE(old.code == 0);
    const std::string script = dir.string() + "/check.sh";
    // $1: the folder written into. Prints the render's exit code, whether the old files are intact
    // and what the folder holds.
    std::ofstream(script) << "cd '" << dir.string() << "' || exit 9\n"
                          << "cp old.exr \"$1/out.exr\" && cp old.png \"$1/out.png\" || exit 9\n"
                          << render << "-D res=256 -o \"$1/out.exr\" 2>&1\n"
                          << "echo \"code=$?\"\n"
                          << "cmp -s old.exr \"$1/out.exr\" && cmp -s old.png \"$1/out.png\" && echo intact\n"
                          << "echo \"files=$(ls -A \"$1\" | tr '\\n' ' ')\"\n";
    auto check = [&](const Run& r, const std::string& why) {
        INFO(why << "\n" << r.output);
        CHECK(r.output.find("code=3") != std::string::npos);
        CHECK(r.output.find("cannot write") != std::string::npos);
        CHECK(r.output.find("intact") != std::string::npos);
        CHECK(r.output.find("files=out.exr out.png \n") != std::string::npos);
    };
    Run probe = sh("unshare -rm sh -c 'mkdir -p " + dir.string() + "/mnt && mount -t tmpfs -o size=128k tmpfs " +
                   dir.string() + "/mnt && echo mounted'");
    if (probe.output.find("mounted") != std::string::npos) {
        Run r = sh("unshare -rm sh -c 'mount -t tmpfs -o size=128k tmpfs " + dir.string() + "/mnt && sh " + script +
                   " " + dir.string() + "/mnt'");
        check(r, "full tmpfs");
        CHECK(r.output.find("No space left on device") != std::string::npos);
    } else {
        WARN("cannot mount a tmpfs in a user namespace here (" << probe.output << "): the full-tmpfs part is skipped");
    }
    fs::create_directories(dir / "limited");
    // 200 blocks of 512 bytes: room for the old files, not for the new EXR.
    Run r = sh("sh -c \"trap '' XFSZ; ulimit -f 200; sh " + script + " " + (dir / "limited").string() + "\"");
    check(r, "file-size limit");
    fs::remove_all(dir);
}

TEST_CASE("SIGINT stops a render after the pass in flight and writes the image of the passes done", "[cli][signals]") {
    // A render of 10^6 passes (64^2) gets SIGINT after 1.5 s: it writes the image and the
    // statistics of the passes it completed (>= 2; about 900 here), says so and exits with 5. The
    // passes are keyed on their index, so the image is bit for bit that of --spp N with the same
    // seed. A second signal (SIGTERM twice, during a pass of a 2048^2 render) exits at once with
    // 128 + 15 and writes nothing.
    fs::path dir = tempDir("signals");
    const std::string render = std::string(LT_RENDER_BIN) + " " + LT_SOURCE_DIR + "/scenes/cornell-box.xml -q ";
    Run r = sh("bash -c '" + render + "-D res=64 --spp 1000000 -o " + (dir / "i.exr").string() + " --stats-json " +
               (dir / "i.json").string() + " & pid=$!; sleep 1.5; kill -INT $pid; wait $pid; echo exit=$?'");
    INFO(r.output);
    CHECK(r.output.find("exit=5") != std::string::npos);
    REQUIRE(fs::exists(dir / "i.json"));
    const auto j = nlohmann::json::parse(std::ifstream(dir / "i.json"));
    const int spp = j["spp"].get<int>();
    CHECK(spp >= 2);
    CHECK(j["interrupted"].get<bool>());
    CHECK(r.output.find("holds " + std::to_string(spp) + " spp of the 1000000 asked") != std::string::npos);
    Run straight = sh(render + "-D res=64 --spp " + std::to_string(spp) + " -o " + (dir / "s.exr").string());
    REQUIRE(straight.code == 0);
    CHECK(samePixels(dir / "i.exr", dir / "s.exr"));

    Run twice = sh("bash -c '" + render + "-D res=2048 --spp 100 -o " + (dir / "big.exr").string() +
                   " & pid=$!; sleep 0.8; kill -TERM $pid; sleep 0.1; kill -TERM $pid; wait $pid; echo exit=$?'");
    INFO(twice.output);
    CHECK(twice.output.find("exit=143") != std::string::npos);
    CHECK_FALSE(fs::exists(dir / "big.exr"));
    fs::remove_all(dir);
}

TEST_CASE("checkpoint and resume: stopped and resumed any number of times, the image of one run straight through", "[cli][checkpoint]") {
    // --spp 3 --checkpoint, then --spp 5 and --spp 8 each resuming and checkpointing again, with 1,
    // 2 and 1 threads: the image must be --spp 8's bit for bit (the passes are keyed on their
    // index: random streams, VCM's radius, the regularisers' schedules), for PT, BPT and VCM, with
    // and without a regulariser. A checkpoint of another integrator, scene, -D define or setting,
    // a damaged one, or --time is refused (exit 1, naming the file).
    fs::path dir = tempDir("checkpoint");
    const std::string scene = std::string(LT_SOURCE_DIR) + "/scenes/cornell-box-glass-sphere.xml -D res=24 -q ";
    const std::string render = std::string(LT_RENDER_BIN) + " ";
    for (const std::string cfg : {"pt", "bpt", "vcm", "pt --reg jg19", "vcm --reg kd13", "bpt --reg opsr"}) {
        INFO(cfg);
        const std::string ck = (dir / "ck").string(), args = scene + "--integrator " + cfg + " ";
        REQUIRE(sh(render + args + "--spp 3 --threads 1 --checkpoint " + ck + " -o " + (dir / "a.exr").string()).code == 0);
        REQUIRE(sh(render + args + "--spp 5 --threads 2 --resume " + ck + " --checkpoint " + ck + " -o " +
                   (dir / "b.exr").string()).code == 0);
        Run last = sh(render + args + "--spp 8 --threads 1 --resume " + ck + " --checkpoint " + ck + " -o " +
                      (dir / "c.exr").string() + " --stats-json " + (dir / "c.json").string());
        INFO(last.output);
        REQUIRE(last.code == 0);
        REQUIRE(sh(render + args + "--spp 8 -o " + (dir / "straight.exr").string()).code == 0);
        CHECK(samePixels(dir / "c.exr", dir / "straight.exr"));
        CHECK(nlohmann::json::parse(std::ifstream(dir / "c.json"))["spp"].get<int>() == 8);
        fs::remove(dir / "ck");
    }
    const std::string ck = (dir / "ck").string();
    {
        // The key holds the regulariser's settings as they apply: a default written out is the
        // same render, a value that changes the image is another.
        const std::string opsr = scene + "--integrator pt --reg opsr ";
        REQUIRE(sh(render + opsr + "--spp 2 --checkpoint " + ck + " -o " + (dir / "a.exr").string()).code == 0);
        Run same = sh(render + opsr + "--reg-tail-rr 0.1 --reg-opsr-gamma 0.01 --spp 4 --resume " + ck + " -o " +
                      (dir / "b.exr").string());
        INFO(same.output);
        CHECK(same.code == 0);
        REQUIRE(sh(render + opsr + "--spp 4 -o " + (dir / "straight.exr").string()).code == 0);
        CHECK(samePixels(dir / "b.exr", dir / "straight.exr"));
        for (const std::string other : {"--reg-tail-rr 0.2", "--reg-opsr-gamma 0.02", "--reg-opsr-consistent"}) {
            Run r = sh(render + opsr + other + " --spp 4 --resume " + ck + " -o " + (dir / "x.exr").string());
            INFO(other << "\n" << r.output);
            CHECK(r.code == 1);
            CHECK(r.output.find("another scene, integrator or settings") != std::string::npos);
        }
        fs::remove(ck);
    }
    REQUIRE(sh(render + scene + "--integrator pt --spp 2 --checkpoint " + ck + " -o " + (dir / "a.exr").string()).code == 0);
    std::string damaged = lt::analysis::readFile(ck);
    damaged.resize(damaged.size() - 100);
    std::ofstream((dir / "damaged").string(), std::ios::binary) << damaged;
    std::string earlier = lt::analysis::readFile(ck);  // a checkpoint of version 1 (another key)
    earlier.replace(0, earlier.find('\n'), "lighttransport checkpoint 1");
    std::ofstream((dir / "earlier").string(), std::ios::binary) << earlier;
    for (const auto& [args, words] : std::vector<std::pair<std::string, std::string>>{
             {scene + "--integrator bpt --spp 4 --resume " + ck, "another scene, integrator or settings"},
             {std::string(LT_SOURCE_DIR) + "/scenes/cornell-box.xml -D res=24 -q --integrator pt --spp 4 --resume " + ck,
              "another scene, integrator or settings"},
             {std::string(LT_SOURCE_DIR) + "/scenes/cornell-box-glass-sphere.xml -D res=25 -q --integrator pt --spp 4 --resume " + ck,
              "another scene, integrator or settings"},
             {scene + "--integrator pt --spp 4 --seed 9 --resume " + ck, "another scene, integrator or settings"},
             {scene + "--integrator pt --spp 4 --resume " + (dir / "damaged").string(), "truncated or damaged"},
             {scene + "--integrator pt --spp 4 --resume " + (dir / "earlier").string(), "another version"},
             {scene + "--integrator pt --spp 1 --resume " + ck, "more than the 1 spp asked"},
             {scene + "--integrator pt --time 1 --checkpoint " + ck, "need a sample count"}}) {
        Run r = sh(render + args + " -o " + (dir / "x.exr").string());
        INFO(args << "\n" << r.output);
        CHECK(r.code == 1);
        CHECK(r.output.find(words) != std::string::npos);
    }
    CHECK_FALSE(fs::exists(dir / "x.exr"));
    fs::remove_all(dir);
}

TEST_CASE("render --guiding: the summary line, the stats, the dump, a checkpoint resumed, and its bad values", "[cli][guiding]") {
    fs::path dir = tempDir("guiding");
    const std::string scene = std::string(LT_SOURCE_DIR) + "/scenes/guiding/ceiling-lit.xml -D res=16 --quiet ";
    const fs::path out = dir / "g.exr", stats = dir / "g.json", dump = dir / "dump";
    Run r = run(scene + "--spp 16 --guiding variance --guiding-bsdf-fraction learned --guiding-spatial-threshold 50 "
                        "--guiding-dump " + dump.string() + " -o " + out.string() + " --stats-json " + stats.string());
    INFO(r.output);
    REQUIRE(r.code == 0);
    CHECK(std::regex_search(r.output, std::regex(R"(guiding variance: 4 iterations, 7 training spp, [0-9]+ spatial leaves)")));
    const nlohmann::json j = nlohmann::json::parse(std::ifstream(stats));
    CHECK(j["guiding"] == "variance");
    CHECK(j["guiding_bsdf_fraction"] == "learned");
    CHECK(j["guiding_iterations"] == 4);
    CHECK(j["guiding_training_spp"] == 7);
    CHECK(j["guiding_bytes"].get<double>() > 0);
    CHECK(fs::file_size(dump / "leaves.png") > 0);
    CHECK(fs::exists(dump / "points.txt"));
    // The state through the checkpoint file: a finished render's checkpoint resumed gives its
    // combined image (tests/test_guiding_pt.cpp stops and resumes mid-render in process). A
    // 16-pass render's state is not a 32-pass one's (the schedule depends on --spp): refused.
    const std::string ck = (dir / "ck").string();
    const std::string g = scene + "--guiding radiance --guiding-spatial-threshold 50 ";
    REQUIRE(run(g + "--spp 32 --threads 1 --checkpoint " + ck + " -o " + (dir / "straight.exr").string()).code == 0);
    Run again = run(g + "--spp 32 --resume " + ck + " -o " + (dir / "again.exr").string());
    INFO(again.output);
    REQUIRE(again.code == 0);
    CHECK(samePixels(dir / "again.exr", dir / "straight.exr"));
    REQUIRE(run(g + "--spp 16 --checkpoint " + ck + " -o " + (dir / "a.exr").string()).code == 0);
    Run other = run(g + "--spp 32 --resume " + ck + " -o " + (dir / "b.exr").string());
    CHECK(other.code != 0);
    CHECK(other.output.find("another sample count") != std::string::npos);
    for (const std::string bad : {"--guiding bogus", "--guiding variance --guiding-bsdf-fraction 0",
                                  "--guiding variance --guiding-bsdf-fraction x", "--guiding variance --integrator bpt",
                                  "--guiding variance --guiding-max-mb 0"}) {
        Run b = run(scene + "--spp 2 " + bad + " -o " + (dir / "bad.exr").string());
        INFO(bad << "\n" << b.output);
        CHECK(b.code == 1);
        CHECK_FALSE(fs::exists(dir / "bad.exr"));
    }
    fs::remove_all(dir);
}
