#pragma once
// Two operations of SUNDIALS' serial N_Vector, replaced by faster ones with
// the same results bit for bit (the compliant integrator installs them on
// its state vector; docs/PERFORMANCE.md, "SUNDIALS vector operations").
//
// Every stage of an explicit Runge-Kutta step forms y_n + h sum_j a_ij k_j,
// and the step's solution and error estimate are two more such sums: ARKODE's
// ERKStep calls N_VLinearCombination for each. The serial vector ships with
// its fused operations off, so SUNDIALS falls back to one N_VScale and
// nvec - 1 N_VLinearSum calls: nvec passes over z, each loading and storing
// it. For Dormand-Prince (7 stages) that is ~40 passes per step, measured as
// 39 % of Scenario 5's instructions, three times its right-hand side.
// ARKODE also copies whole states with N_VScale(1, x, z) about twice a step,
// element by element.

#include <nvector/nvector_serial.h>

namespace ringsim {

// z = sum_i c[i] X[i] in one pass: each element stays in a register while
// the vectors are summed, in the fallback's order (c_0 x_0 + c_1 x_1 + ...,
// a product and an add per term), so the values are the same bit for bit.
// z may be one of the X (ARKODE passes y_n as X[0] and as z). Returns -1 for
// nvec < 1, like SUNDIALS.
int one_pass_linear_combination(int nvec, sunrealtype* c, N_Vector* X, N_Vector z);

// z = c x; a copy (memcpy) when c = 1. Same values as N_VScale_Serial.
void one_pass_scale(sunrealtype c, N_Vector x, N_Vector z);

// Installs both in v's operation table (a serial vector). Call it before a
// solver clones v: clones copy the table.
void use_one_pass_operations(N_Vector v);

}  // namespace ringsim
