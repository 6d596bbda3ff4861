// The MPI form of Cluster (cluster.h): the pass counter is one 64-bit integer in a window on
// rank 0, advanced by MPI_Fetch_and_op (passive target, so no rank waits for another to hand out
// a pass); the films are added along a binomial tree of point-to-point messages (the sums are
// exact, so the tree's order does not matter).
#include <mpi.h>

#include <algorithm>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/film.h"
#include "integrators/distributed/cluster.h"

namespace lt::dist {

namespace {

void check(int rc, const char* what) {
    if (rc != MPI_SUCCESS) throw std::runtime_error(std::string("MPI: ") + what + " failed");
}

// Whether an MPI launcher started this process (Open MPI's mpirun, PMIx: srun and others, PMI).
bool launchedByMpi() {
    for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"})
        if (std::getenv(v)) return true;
    return false;
}

// Messages of any size: MPI counts are ints, so a film's bytes go in pieces of at most 1 GiB.
constexpr size_t kPiece = size_t(1) << 30;
void sendBytes(const std::string& bytes, int to) {
    const uint64_t n = bytes.size();
    check(MPI_Send(&n, 1, MPI_UINT64_T, to, 0, MPI_COMM_WORLD), "MPI_Send");
    for (size_t at = 0; at < n; at += kPiece)
        check(MPI_Send(bytes.data() + at, int(std::min(kPiece, n - at)), MPI_BYTE, to, 1, MPI_COMM_WORLD), "MPI_Send");
}
std::string receiveBytes(int from) {
    uint64_t n = 0;
    check(MPI_Recv(&n, 1, MPI_UINT64_T, from, 0, MPI_COMM_WORLD, MPI_STATUS_IGNORE), "MPI_Recv");
    std::string bytes(n, '\0');
    for (size_t at = 0; at < n; at += kPiece)
        check(MPI_Recv(bytes.data() + at, int(std::min(kPiece, n - at)), MPI_BYTE, from, 1, MPI_COMM_WORLD,
                       MPI_STATUS_IGNORE),
              "MPI_Recv");
    return bytes;
}

class MpiCluster final : public Cluster {
public:
    MpiCluster() {
        check(MPI_Comm_rank(MPI_COMM_WORLD, &rank_), "MPI_Comm_rank");
        check(MPI_Comm_size(MPI_COMM_WORLD, &size_), "MPI_Comm_size");
        const MPI_Aint bytes = rank_ == 0 ? MPI_Aint(sizeof(uint64_t)) : 0;
        check(MPI_Win_allocate(bytes, sizeof(uint64_t), MPI_INFO_NULL, MPI_COMM_WORLD, &counter_, &win_),
              "MPI_Win_allocate");
        check(MPI_Win_lock_all(0, win_), "MPI_Win_lock_all");
    }
    ~MpiCluster() override {
        MPI_Win_unlock_all(win_);
        MPI_Win_free(&win_);
    }
    int rank() const override { return rank_; }
    int size() const override { return size_; }

    void startPasses(uint64_t first) override {
        check(MPI_Barrier(MPI_COMM_WORLD), "MPI_Barrier");  // (no rank still reads the last render's counter)
        if (rank_ == 0) {
            uint64_t ignored;
            check(MPI_Fetch_and_op(&first, &ignored, MPI_UINT64_T, 0, 0, MPI_REPLACE, win_), "MPI_Fetch_and_op");
            check(MPI_Win_flush(0, win_), "MPI_Win_flush");
        }
        check(MPI_Barrier(MPI_COMM_WORLD), "MPI_Barrier");
    }
    uint64_t nextPass() override { return fetch(1, MPI_SUM); }
    uint64_t close() override { return fetch(kClosed, MPI_REPLACE); }

    uint64_t sum(uint64_t v) override { return reduce(v, MPI_SUM); }
    uint64_t max(uint64_t v) override { return reduce(v, MPI_MAX); }
    double valueAtLargest(uint64_t key, double v) override {
        const double mine[2] = {double(key), v};  // (keys are pass counts: exact in a double)
        std::vector<double> all(2 * size_t(size_));
        check(MPI_Allgather(mine, 2, MPI_DOUBLE, all.data(), 2, MPI_DOUBLE, MPI_COMM_WORLD), "MPI_Allgather");
        size_t best = 0;
        for (size_t r = 1; r < size_t(size_); ++r)
            if (all[2 * r] > all[2 * best]) best = r;
        return all[2 * best + 1];
    }
    std::vector<uint64_t> gather(uint64_t v) override {
        std::vector<uint64_t> all(size_t(size_), 0);
        check(MPI_Allgather(&v, 1, MPI_UINT64_T, all.data(), 1, MPI_UINT64_T, MPI_COMM_WORLD), "MPI_Allgather");
        return all;
    }
    std::string broadcast(const std::string& bytes, int from) override {
        uint64_t n = bytes.size();
        check(MPI_Bcast(&n, 1, MPI_UINT64_T, from, MPI_COMM_WORLD), "MPI_Bcast");
        std::string out = rank_ == from ? bytes : std::string(n, '\0');
        for (size_t at = 0; at < n; at += kPiece)
            check(MPI_Bcast(out.data() + at, int(std::min(kPiece, n - at)), MPI_BYTE, from, MPI_COMM_WORLD), "MPI_Bcast");
        return out;
    }
    std::vector<std::string> gatherBytes(const std::string& bytes) override {
        if (rank_ != 0) {
            sendBytes(bytes, 0);
            return {};
        }
        std::vector<std::string> all(static_cast<size_t>(size_));
        all[0] = bytes;
        for (int r = 1; r < size_; ++r) all[size_t(r)] = receiveBytes(r);
        return all;
    }
    void reduceFilm(Film& film) override {
        // Binomial tree: at step s, ranks that are multiples of 2s take the film of rank + s.
        for (int step = 1; step < size_; step *= 2) {
            if (rank_ % (2 * step) == 0) {
                if (rank_ + step < size_) film.addState(receiveBytes(rank_ + step));
            } else {
                sendBytes(film.state(), rank_ - step);
                break;
            }
        }
    }

private:
    uint64_t fetch(uint64_t operand, MPI_Op op) {
        uint64_t result = 0;
        check(MPI_Fetch_and_op(&operand, &result, MPI_UINT64_T, 0, 0, op, win_), "MPI_Fetch_and_op");
        check(MPI_Win_flush(0, win_), "MPI_Win_flush");
        return result;
    }
    uint64_t reduce(uint64_t v, MPI_Op op) {
        uint64_t out = 0;
        check(MPI_Allreduce(&v, &out, 1, MPI_UINT64_T, op, MPI_COMM_WORLD), "MPI_Allreduce");
        return out;
    }
    int rank_ = 0, size_ = 1;
    uint64_t* counter_ = nullptr;
    MPI_Win win_ = MPI_WIN_NULL;
};

}  // namespace

std::unique_ptr<Cluster> startMpi(int& argc, char**& argv) {
    if (!launchedByMpi()) return nullptr;
    int provided = 0;
    // (only the main thread calls MPI; the render's threads never do)
    check(MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
    return std::make_unique<MpiCluster>();
}

void stopMpi() { MPI_Finalize(); }

void abortMpi(int code) {
    MPI_Abort(MPI_COMM_WORLD, code);
    std::exit(code);
}

}  // namespace lt::dist
