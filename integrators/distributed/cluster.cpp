#include "integrators/distributed/cluster.h"

#include <cstdio>
#include <cstdlib>

namespace lt::dist {

#ifdef LT_HAVE_MPI
std::unique_ptr<Cluster> startMpi(int& argc, char**& argv);  // mpi_cluster.cpp (null: no launcher)
void stopMpi();
[[noreturn]] void abortMpi(int code);
bool mpiBuilt() { return true; }
#else
bool mpiBuilt() { return false; }
#endif

Session::Session(int& argc, char**& argv) {
#ifdef LT_HAVE_MPI
    cluster_ = startMpi(argc, argv);
#else
    (void)argc;
    (void)argv;
#endif
}

Session::~Session() {
#ifdef LT_HAVE_MPI
    if (cluster_) {
        cluster_.reset();
        stopMpi();
    }
#endif
}

int Session::run(const std::function<int()>& run, int interrupted) const {
    if (!root() && (!std::freopen("/dev/null", "w", stderr) || !std::freopen("/dev/null", "w", stdout))) abort(4);
    const int rc = run();
    if (cluster_ && rc != 0 && rc != interrupted) abort(rc);
    return rc;
}

void Session::abort(int code) const {
#ifdef LT_HAVE_MPI
    if (cluster_) abortMpi(code);
#endif
    std::exit(code);
}

}  // namespace lt::dist
