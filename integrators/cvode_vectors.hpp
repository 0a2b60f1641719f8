// The SUNDIALS plumbing of the CVODE integrator (cvode.hpp): owning handles for SUNDIALS
// objects, and the serial vectors' operation table replaced by vectorised kernels.
#pragma once
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sundials/sundials_linearsolver.h>

#include <memory>
#include <type_traits>

namespace jamflow::cvode_detail {

void free_cvode_memory(void* mem);  // CVodeFree

struct ContextFree {
  void operator()(SUNContext c) const { SUNContext_Free(&c); }
};
struct VectorFree {
  void operator()(N_Vector v) const { N_VDestroy(v); }
};
struct LinSolFree {
  void operator()(SUNLinearSolver s) const { SUNLinSolFree(s); }
};
struct CvodeFree {
  void operator()(void* m) const { free_cvode_memory(m); }
};
using ContextPtr = std::unique_ptr<std::remove_pointer_t<SUNContext>, ContextFree>;
using VectorPtr = std::unique_ptr<std::remove_pointer_t<N_Vector>, VectorFree>;
using LinSolPtr = std::unique_ptr<std::remove_pointer_t<SUNLinearSolver>, LinSolFree>;
using CvodeMemPtr = std::unique_ptr<void, CvodeFree>;

inline double* data(N_Vector v) {
  return N_VGetArrayPointer(v);
}

// Debian's SUNDIALS 6.4.1 is built without optimisation (its N_VDotProd_Serial runs at ~9 ns per
// element), so every operation CVODE and the Krylov solvers use gets an Eigen / OpenMP-SIMD
// kernel in v's operation table (clones copy the table). Semantics follow nvector_serial;
// cvode_kernel_discrepancy (cvode.hpp) checks them against the library's own.
void install_kernels(N_Vector v);

}  // namespace jamflow::cvode_detail
