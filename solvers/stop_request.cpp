#include "solvers/stop_request.hpp"

#include <csignal>

namespace hyperqn {

namespace {
volatile std::sig_atomic_t g_signal = 0;  // the handler writes it, nothing else does
bool g_agreed = false;                    // changed only with every rank's reduced votes
}  // namespace

void record_stop_signal(int sig) { g_signal = sig; }
int stop_signal() { return (int)g_signal; }

double stop_vote() { return g_signal != 0 ? 1.0 : 0.0; }
void count_stop_votes(double sum) { g_agreed = g_agreed || sum > 0; }
bool stop_agreed() { return g_agreed; }

int stop_signal_on_any_rank(MPI_Comm comm) {
  int sig = stop_signal(), any = 0;
  MPI_Allreduce(&sig, &any, 1, MPI_INT, MPI_MAX, comm);
  return any;
}
const char* stop_signal_name(int sig) { return sig == SIGTERM ? "SIGTERM" : sig == SIGINT ? "SIGINT" : "SIGUSR1"; }

}  // namespace hyperqn
