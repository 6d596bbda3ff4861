// The processes of one render (issue 48): MPI ranks started by mpirun or srun, each with its own
// threads. They render disjoint sets of passes of one render, handed out on demand by one shared
// counter (a rank twice as fast renders about twice the passes), and add their films exactly
// (core/exact_sum.h) at the end, so the image is the single-process one bit for bit for any number
// of ranks and threads. Rank 0 decides when a --time render stops, and writes every output.
//
// A pass once handed out is always rendered, so the passes done are the prefix [0, P) of the
// passes handed out before the counter closed: the image of a render stopped by time or by a
// signal is the single-process image of P passes.
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace lt {
class Film;
}

namespace lt::dist {

class Cluster {
public:
    // What nextPass() returns once the counter is closed (close()).
    static constexpr uint64_t kClosed = uint64_t(1) << 62;

    virtual ~Cluster() = default;
    virtual int rank() const = 0;
    virtual int size() const = 0;
    bool root() const { return rank() == 0; }

    // Collective: the counter starts at `first` (the passes a resumed render holds).
    virtual void startPasses(uint64_t first) = 0;
    // The next pass for this rank (each index goes to one rank); >= kClosed after close().
    virtual uint64_t nextPass() = 0;
    // Closes the counter: the number of passes handed out before (>= kClosed where another rank
    // closed it first). Any rank may call it (a time limit on rank 0, a signal anywhere).
    virtual uint64_t close() = 0;

    // Collectives over every rank.
    virtual uint64_t sum(uint64_t v) = 0;
    virtual uint64_t max(uint64_t v) = 0;
    virtual double valueAtLargest(uint64_t key, double v) = 0;  // v of the rank with the largest key
    virtual std::vector<uint64_t> gather(uint64_t v) = 0;        // every rank's v, by rank
    // Bytes of any size: rank `from`'s, on every rank; every rank's, by rank, on rank 0 (the
    // others get an empty vector).
    virtual std::string broadcast(const std::string& bytes, int from) = 0;
    virtual std::vector<std::string> gatherBytes(const std::string& bytes) = 0;
    // Adds every rank's film into rank 0's (Film::addState, exact: any order gives the same bits);
    // the other ranks' films are left as they were.
    virtual void reduceFilm(Film& film) = 0;
};

// MPI for the lifetime of a program: initialised when the process was started by an MPI launcher
// (Open MPI's or a PMIx/PMI one sets the environment), finalised at the end. Without a launcher,
// or in a build without MPI, there is no cluster and the program runs alone, as it always did.
class Session {
public:
    Session(int& argc, char**& argv);
    ~Session();
    Session(const Session&) = delete;
    Session& operator=(const Session&) = delete;
    // The cluster of this run (null: alone).
    Cluster* cluster() const { return cluster_.get(); }
    bool root() const { return !cluster_ || cluster_->root(); }
    // Ends every rank at once (MPI_Abort) with `code`, e.g. where one rank fails and the others
    // would wait for it in a collective; alone: std::exit.
    [[noreturn]] void abort(int code) const;
    // A tool's main under a launcher: runs `run` with the ranks other than 0 silenced (every rank
    // runs the same checks and would print the same messages), and ends every rank where one
    // returns an error (anything but 0 and `interrupted`), as the others would wait for it in a
    // collective.
    int run(const std::function<int()>& run, int interrupted = 0) const;

private:
    std::unique_ptr<Cluster> cluster_;
};

// Whether this build can run with MPI.
bool mpiBuilt();

}  // namespace lt::dist
