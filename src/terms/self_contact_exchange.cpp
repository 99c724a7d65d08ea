// Self-contact's ghost layer (terms/self_contact.hpp): which surface vertices' positions each rank
// sends to which, and the nonblocking exchange of their values along such a plan.
#include <algorithm>
#include <cmath>

#include "geometry/box_tree.hpp"
#include "parallel/collectives.hpp"
#include "terms/self_contact.hpp"

namespace hyperqn {

using Vec3 = Eigen::Vector3d;

SelfContactTerm::Exchange SelfContactTerm::make_exchange(std::vector<std::pair<int, int>> sends,
                                                         std::vector<std::pair<int, int>> receives) const {
  PetscMPIInt size;
  MPI_Comm_size(PetscObjectComm((PetscObject)mesh_.dm), &size);
  Exchange plan;
  const auto fill = [size](std::vector<std::pair<int, int>>& pairs, std::vector<int>& list, std::vector<int>& offsets) {
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    offsets.assign(size + 1, 0);
    for (const auto& [r, s] : pairs) ++offsets[r + 1], list.push_back(s);
    for (int r = 0; r < size; ++r) offsets[r + 1] += offsets[r];
  };
  fill(sends, plan.send, plan.send_offsets);
  fill(receives, plan.recv, plan.recv_offsets);
  plan.known.assign(ids_.size(), 0);
  for (int s : owned_surface_) plan.known[s] = 1;
  for (int s : plan.recv) plan.known[s] = 1;
  for (size_t s = 0; s < ids_.size(); ++s)
    if (plan.known[s]) plan.known_list.push_back((int)s);
  return plan;
}

PetscErrorCode SelfContactTerm::plan_exchange(const std::vector<double>& x, const std::vector<double>* end, double reach,
                                              Exchange* plan) const {
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh_.dm);
  PetscMPIInt size, rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  const auto p = [&](int s) { return Vec3(&x[3 * s]); };
  const auto q = [&](int s) { return end ? Vec3(&(*end)[3 * s]) : Vec3(&x[3 * s]); };
  // This rank's region: the box of its own vertices and edges (the pairs it evaluates) and its
  // triangles (the start's crossing test), grown by reach; lo > hi if it has none.
  std::vector<double> region{HUGE_VAL, HUGE_VAL, HUGE_VAL, -HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  const auto take = [&](int s) {
    for (int d = 0; d < 3; ++d) {
      region[d] = std::min({region[d], p(s)[d], q(s)[d]});
      region[3 + d] = std::max({region[3 + d], p(s)[d], q(s)[d]});
    }
  };
  for (int s : my_vertices_) take(s);
  for (int e : my_edges_) take(edges_[e][1]);
  for (int t : my_triangles_)
    for (int s : triangles_[t]) take(s);
  for (int d = 0; d < 3; ++d) region[d] -= reach, region[3 + d] += reach;
  const std::vector<double> regions = all_gathered(comm, region, MPI_DOUBLE);
  std::vector<Box> boxes;
  std::vector<int> rank_of;
  for (int r = 0; r < size; ++r)
    if (r != rank && regions[6 * r] <= regions[6 * r + 3]) {
      boxes.push_back({Vec3(&regions[6 * r]), Vec3(&regions[6 * r + 3])});
      rank_of.push_back(r);
    }
  const BoxTree others(std::move(boxes));
  // Each of this rank's triangles and edges that overlaps another rank's region: its vertices are
  // asked of their owners for that rank, as (rank, vertex) pairs.
  std::vector<std::vector<int>> asks(size);
  const auto ask = [&](const Box& box, std::initializer_list<int> vertices) {
    others.overlapping(box, [&](int i) {
      for (int s : vertices)
        if (owner_[s] != rank_of[i]) asks[owner_[s]].insert(asks[owner_[s]].end(), {rank_of[i], s});
    });
  };
  for (int t : my_triangles_) {
    const auto& v = triangles_[t];
    ask(Box::around({p(v[0]), p(v[1]), p(v[2]), q(v[0]), q(v[1]), q(v[2])}, 0), {v[0], v[1], v[2]});
  }
  for (int e : my_edges_) {
    const auto& v = edges_[e];
    ask(Box::around({p(v[0]), p(v[1]), q(v[0]), q(v[1])}, 0), {v[0], v[1]});
  }
  // The vertices of this rank's frozen friction pairs, which may have moved out of reach.
  for (const auto& frozen : friction_)
    for (int s : points(frozen.first))
      if (owner_[s] != rank) asks[owner_[s]].insert(asks[owner_[s]].end(), {rank, s});
  // To the owners; each owner sends its halo and what it was asked, and tells each rank which.
  std::vector<int> flat, counts(size), offsets(size + 1, 0);
  for (int r = 0; r < size; ++r) flat.insert(flat.end(), asks[r].begin(), asks[r].end()), counts[r] = (int)asks[r].size();
  for (int r = 0; r < size; ++r) offsets[r + 1] = offsets[r] + counts[r];
  std::vector<int> asked = all_to_all(comm, flat, counts, offsets);
  std::vector<std::pair<int, int>> sends = halo_;
  for (size_t k = 0; k < asked.size(); k += 2) sends.push_back({asked[k], asked[k + 1]});
  std::sort(sends.begin(), sends.end());
  sends.erase(std::unique(sends.begin(), sends.end()), sends.end());
  flat.clear();
  std::fill(counts.begin(), counts.end(), 0);
  for (const auto& [r, s] : sends) flat.push_back(s), ++counts[r];
  for (int r = 0; r < size; ++r) offsets[r + 1] = offsets[r] + counts[r];
  std::vector<int> told_counts;
  const std::vector<int> told = all_to_all(comm, flat, counts, offsets, &told_counts);
  std::vector<std::pair<int, int>> receives;
  for (int r = 0, k = 0; r < size; ++r)
    for (int j = 0; j < told_counts[r]; ++j) receives.push_back({r, told[k++]});
  *plan = make_exchange(std::move(sends), std::move(receives));
  PetscFunctionReturn(0);
}

PetscErrorCode SelfContactTerm::exchange(const Exchange& plan, int width, std::vector<double>& values) const {
  MPI_Comm comm = PetscObjectComm((PetscObject)mesh_.dm);
  PetscMPIInt size;
  std::vector<MPI_Request>& requests = requests_;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  requests.clear();
  out_.resize(width * plan.send.size());
  buffer_.resize(width * plan.recv.size());
  for (size_t k = 0; k < plan.send.size(); ++k)
    std::copy_n(&values[width * plan.send[k]], width, &out_[width * k]);
  for (int r = 0; r < size; ++r) {
    const int n = plan.recv_offsets[r + 1] - plan.recv_offsets[r];
    if (n == 0) continue;
    requests.emplace_back();
    PetscCallMPI(MPI_Irecv(&buffer_[width * plan.recv_offsets[r]], width * n, MPI_DOUBLE, r, tag_, comm, &requests.back()));
  }
  for (int r = 0; r < size; ++r) {
    const int n = plan.send_offsets[r + 1] - plan.send_offsets[r];
    if (n == 0) continue;
    requests.emplace_back();
    PetscCallMPI(MPI_Isend(&out_[width * plan.send_offsets[r]], width * n, MPI_DOUBLE, r, tag_, comm, &requests.back()));
  }
  PetscCallMPI(MPI_Waitall((int)requests.size(), requests.data(), MPI_STATUSES_IGNORE));
  for (size_t k = 0; k < plan.recv.size(); ++k)
    std::copy_n(&buffer_[width * k], width, &values[width * plan.recv[k]]);
  PetscFunctionReturn(0);
}

}  // namespace hyperqn
