"""Warp kernels of one MLS-MPM step (APIC transfers, quadratic B-splines), generic over float32/float64.

One step is ``eigen`` (eigen-decomposition of the trial strain for the Hencky models, by Jacobi rotations from the
last step's basis) and ``reached_nodes`` (the box of nodes the particles reach), then three differentiated launches:
``p2g`` (constitutive update and particle-to-grid transfer), ``grid_update`` (gravity and boundaries, over that box)
and ``g2p`` (grid-to-particle transfer and advection); about a plane of symmetry, ``mirror_fold`` adds the mirror
images' share to the grid after ``p2g``. Between transfers a few steps apart, a step holds the particles in place
and advances the grid's momentum alone: ``grid_gradient`` (the velocity gradient at the particles), ``eigen``,
``p2g`` without the transfer (the stress' impulse alone), ``add_momentum``, ``grid_update``. A thixotropic material's
``structure_update`` accumulates each particle's plastic shear strain (``OptionalPhysics``: it lowers the yield
stress in ``p2g``; air drag, wall adhesion and the open drag act in ``grid_update``; surface tension is the impulse
that ``capillary_force`` adds to the grid's momentum from the cells' ``capillary_stress``, before ``grid_update``).
Every input a loss may depend on (particle state, material parameters, boundary parameters) is a Warp array, so
Warp's generated adjoints give the gradients.
The plastic return on Hencky strain has a hand-written adjoint (divided differences of the eigenvalues) that stays
finite at repeated eigenvalues (undeformed material) and needs no second decomposition in the backward pass.

Stress conventions: Kirchhoff stress ``tau``; deviatoric norm ``|s|``; equivalent shear stress ``|s| / sqrt(2)``,
which is what ``tau_y`` and the Herschel-Bulkley law refer to (``tau = tau_y + K gamma_dot^n`` in simple shear).
"""


import functools
from types import SimpleNamespace

import warp as wp

wp.config.quiet = True

# Constitutive models (index into the p2g branch).
MODEL_HERSCHEL_BULKLEY = 0
MODEL_PLASTICINE = 1
MODEL_NEWTONIAN = 2
MODEL_NEO_HOOKEAN = 3

# Layout of the material parameter array passed to the kernels.
P_MU, P_LAM, P_TAU_Y, P_K, P_N, P_RHO = range(6)
N_MATERIAL_PARAMS = 6

# Collider shapes, contact laws and layouts of the collider arrays.
SHAPE_FLOOR = 0  # half-space y <= geom[0] (y is up)
SHAPE_BOX = 1  # axis-aligned box: centre geom[0:3], half extents geom[3:6]
SHAPE_CUP = 2  # open-bottomed truncated-cone shell, see boundaries.Cup
CONTACT_STICKY = 0
CONTACT_SLIP = 1
CONTACT_FRICTION = 2
CONTACT_NAVIER = 3
N_GEOM = 8
B_FRICTION, B_VX, B_VY, B_VZ = range(4)
N_BOUNDARY_PARAMS = 4
MAX_COLLIDERS = 8

BOUND = 3  # grid nodes next to each domain face that act as slip walls; particles must stay inside them
# nodes less than this many cells inside a Navier wall carry its traction: one layer, whatever the rounding
NAVIER_LAYER = 0.99
MIRROR_NODES = 3  # node planes folded on either side of a plane of symmetry: more than a particle's stencil reaches

# Most cyclic Jacobi sweeps of an eigen-decomposition (convergence is quadratic: from the identity a strained b takes
# three or four, from the last step's basis one or two).
JACOBI_SWEEPS = 8

# Below this relative gap two eigenvalues are treated as one and divided differences use a series.
_SERIES_GAP = 1e-2


@functools.cache
def build(scalar: type) -> SimpleNamespace:
    """Compile-ready kernels for one scalar type (``wp.float32`` or ``wp.float64``)."""
    vec3 = wp.types.vector(3, scalar)
    vec4 = wp.types.vector(4, scalar)
    mat33 = wp.types.matrix((3, 3), scalar)
    mat63 = wp.types.matrix((6, 3), scalar)
    zero = scalar(0.0)
    one = scalar(1.0)
    half = scalar(0.5)
    third = scalar(1.0 / 3.0)
    sqrt2 = scalar(2.0**0.5)
    series_gap = scalar(_SERIES_GAP)
    tiny = scalar(1e-30)
    min_eig = scalar(1e-12)
    # squared off-diagonal size, relative to the diagonal's, at which the Jacobi rotations stop: the scalar's precision
    jacobi_tolerance = scalar(1e-12 if scalar is wp.float32 else 1e-26)
    # relative step at which Halley's iteration stops: the next error, about its cube, is below the precision
    halley_tolerance = scalar(1e-4 if scalar is wp.float32 else 1e-7)

    @wp.func
    def log_divided(a: scalar, b: scalar) -> scalar:
        """(log a - log b) / (a - b), exact also when a and b (both > 0) nearly coincide."""
        r = (a - b) / b
        if wp.abs(r) < series_gap:
            r2 = r * r
            return (one - half * r + r2 * third - scalar(0.25) * r2 * r + scalar(0.2) * r2 * r2
                    - r2 * r2 * r / scalar(6.0)) / b
        return (wp.log(a) - wp.log(b)) / (a - b)

    @wp.func
    def exp_divided(a: scalar, b: scalar) -> scalar:
        """(exp a - exp b) / (a - b), exact also when a and b nearly coincide."""
        d = a - b
        if wp.abs(d) < series_gap:
            d2 = d * d
            return wp.exp(b) * (one + half * d + d2 / scalar(6.0) + d2 * d / scalar(24.0)
                                + d2 * d2 / scalar(120.0) + d2 * d2 * d / scalar(720.0))
        return (wp.exp(a) - wp.exp(b)) / d

    @wp.func
    def halley_step(g: scalar, dg: scalar, d2g: scalar) -> scalar:
        """The step of Halley's method on g (first and second derivatives dg > 0, d2g), or Newton's where Halley's
        denominator 2 dg^2 - g d2g falls below dg^2 (far from the root)."""
        denominator = scalar(2.0) * dg * dg - g * d2g
        if denominator > dg * dg:
            return scalar(2.0) * g * dg / denominator
        return g / dg

    @wp.func
    def hb_excess(excess_trial: scalar, relax: scalar, K: scalar, n: scalar) -> scalar:
        """Stress excess u = t - tau_y after one backward-Euler Herschel-Bulkley step.

        Solves ``u + relax * (u / K)^(1/n) = excess_trial`` (``relax = mu dt``): in closed form for n = 1, else by
        Halley's method on the convex form of the equation (Newton's where Halley's correction is ill-conditioned),
        started above the root. Its cubic convergence stops after a relative step of ``halley_tolerance``: from the
        usual start (the trial excess, a few per cent above the root) two powers, where Newton's method took four.
        """
        if excess_trial <= zero:
            return zero
        if n == one:
            return excess_trial * K / (K + relax)
        m = one / n
        u = zero
        if n < one:
            # g(u) = u + relax (u/K)^m - excess_trial is convex in u; start at the smaller of two upper bounds,
            # u = excess_trial or, where g is above excess_trial there (rarely), K (excess_trial / relax)^n.
            u = excess_trial
            for i in range(40):
                q = wp.pow(u / K, m)
                if i == 0 and relax * q > excess_trial:
                    u = K * wp.pow(excess_trial / relax, n)
                    q = excess_trial / relax
                g = u + relax * q - excess_trial
                slope = relax * m * q / wp.max(u, tiny)
                u_next = wp.max(u - halley_step(g, one + slope, slope * (m - one) / wp.max(u, tiny)), zero)
                converged = wp.abs(u_next - u) <= halley_tolerance * u_next
                u = u_next
                if converged:
                    break
        else:
            # In the shear rate w, h(w) = K w^n + relax w - excess_trial is convex; start at the smaller of two
            # upper bounds, w = excess_trial / relax or, where h is above excess_trial there, (excess_trial / K)^m.
            w = excess_trial / relax
            for i in range(40):
                q = K * wp.pow(w, n)
                if i == 0 and q > excess_trial:
                    w = wp.pow(excess_trial / K, m)
                    q = excess_trial
                h = q + relax * w - excess_trial
                slope = n * q / wp.max(w, tiny)
                w_next = wp.max(w - halley_step(h, slope + relax, slope * (n - one) / wp.max(w, tiny)), zero)
                converged = wp.abs(w_next - w) <= halley_tolerance * w_next
                w = w_next
                if converged:
                    break
            u = K * wp.pow(w, n)
        return u

    @wp.func
    def jacobi_rotation(app: scalar, aqq: scalar, apq: scalar, arp: scalar, arq: scalar, vp: vec3, vq: vec3):
        """The rotation of a symmetric matrix's basis columns ``vp``, ``vq`` that zeroes its entry a_pq: the new
        a_pp, a_qq, a_rp, a_rq (r the third index), vp and vq, in the rounding-stable form of Numerical Recipes."""
        if apq == zero:
            return app, aqq, arp, arq, vp, vq
        theta = (aqq - app) / (scalar(2.0) * apq)
        t = one / (wp.abs(theta) + wp.sqrt(theta * theta + one))
        if theta < zero:
            t = -t
        c = one / wp.sqrt(t * t + one)
        s = t * c
        tau = s / (one + c)
        return (app - t * apq, aqq + t * apq, arp - s * (arq + tau * arp), arq + s * (arp - tau * arq),
                vp - s * (vq + tau * vp), vq + s * (vp - tau * vq))

    @wp.func
    def eigen(b: mat33, guess: mat33):
        """b = Q diag(l) Q^T (b symmetric), by cyclic Jacobi rotations from the orthonormalised columns of ``guess``
        until the off-diagonal part is below the scalar's precision. From the last step's Q, b has barely turned and
        one or two sweeps suffice."""
        c0 = wp.normalize(vec3(guess[0, 0], guess[1, 0], guess[2, 0]))
        c1 = vec3(guess[0, 1], guess[1, 1], guess[2, 1])
        c1 = wp.normalize(c1 - wp.dot(c0, c1) * c0)
        c2 = wp.cross(c0, c1)
        b0 = b * c0
        b1 = b * c1
        b2 = b * c2
        a00 = wp.dot(c0, b0)
        a11 = wp.dot(c1, b1)
        a22 = wp.dot(c2, b2)
        a01 = wp.dot(c0, b1)
        a02 = wp.dot(c0, b2)
        a12 = wp.dot(c1, b2)
        for _sweep in range(JACOBI_SWEEPS):
            if a01 * a01 + a02 * a02 + a12 * a12 <= jacobi_tolerance * (a00 * a00 + a11 * a11 + a22 * a22):
                break
            a00, a11, a02, a12, c0, c1 = jacobi_rotation(a00, a11, a01, a02, a12, c0, c1)
            a01 = zero
            a11, a22, a01, a02, c1, c2 = jacobi_rotation(a11, a22, a12, a01, a02, c1, c2)
            a12 = zero
            a00, a22, a01, a12, c0, c2 = jacobi_rotation(a00, a22, a02, a01, a12, c0, c2)
            a02 = zero
        return wp.matrix_from_cols(c0, c1, c2), vec3(wp.max(a00, min_eig), wp.max(a11, min_eig), wp.max(a22, min_eig))

    @wp.func
    def yield_scale(e: vec3, mu: scalar, tau_y: scalar, K: scalar, n: scalar, dt: scalar, model: int) -> scalar:
        """alpha = |s_new| / |s_trial| of the return mapping (1 below yield)."""
        t_trial = sqrt2 * mu * wp.sqrt(wp.dot(e, e) + tiny)
        alpha = one
        if t_trial > tau_y:
            t_new = tau_y
            if model == MODEL_HERSCHEL_BULKLEY:
                t_new = tau_y + hb_excess(t_trial - tau_y, mu * dt, K, n)
            alpha = t_new / t_trial
        return alpha

    @wp.func
    def hencky_return(b: mat33, Q: mat33, l: vec3, mu: scalar, lam: scalar, tau_y: scalar, K: scalar, n: scalar,
                      dt: scalar, model: int) -> mat63:
        """Plastic return on Hencky strain from b = Ft Ft^T = Q diag(l) Q^T. Rows 0-2: P with F_new = P Ft; rows 3-5:
        Kirchhoff stress. The eigen-decomposition (Q, l) is computed beforehand by ``eigen_kernel``, outside the
        differentiated code: the adjoint below gives the whole derivative with respect to b (Daleckii-Krein divided
        differences, finite at repeated eigenvalues), so the backward pass never decomposes a matrix."""
        eps = half * vec3(wp.log(l[0]), wp.log(l[1]), wp.log(l[2]))
        tr = eps[0] + eps[1] + eps[2]
        e = eps - vec3(third * tr)
        alpha = yield_scale(e, mu, tau_y, K, n, dt, model)
        beta = alpha - one
        kappa = scalar(2.0 / 3.0) * mu + lam
        QT = wp.transpose(Q)
        P = wp.identity(3, dtype=scalar)
        if beta != zero:  # yielded
            P = Q * wp.diag(vec3(wp.exp(beta * e[0]), wp.exp(beta * e[1]), wp.exp(beta * e[2]))) * QT
        T = Q * wp.diag(scalar(2.0) * mu * alpha * e + vec3(kappa * tr)) * QT
        out = mat63()
        for i in range(3):
            for j in range(3):
                out[i, j] = P[i, j]
                out[i + 3, j] = T[i, j]
        return out

    @wp.func_grad(hencky_return)
    def adj_hencky_return(b: mat33, Q: mat33, l: vec3, mu: scalar, lam: scalar, tau_y: scalar, K: scalar,
                          n: scalar, dt: scalar, model: int, adj_ret: mat63):
        eps = half * vec3(wp.log(l[0]), wp.log(l[1]), wp.log(l[2]))
        tr = eps[0] + eps[1] + eps[2]
        e = eps - vec3(third * tr)
        r = wp.sqrt(wp.dot(e, e) + tiny)
        t_trial = sqrt2 * mu * r
        alpha = yield_scale(e, mu, tau_y, K, n, dt, model)
        beta = alpha - one
        kappa = scalar(2.0 / 3.0) * mu + lam
        p = vec3(wp.exp(beta * e[0]), wp.exp(beta * e[1]), wp.exp(beta * e[2]))
        adj_P = mat33()
        adj_T = mat33()
        for i in range(3):
            for j in range(3):
                adj_P[i, j] = adj_ret[i, j]
                adj_T[i, j] = adj_ret[i + 3, j]
        QT = wp.transpose(Q)
        Ap = QT * (adj_P + wp.transpose(adj_P)) * Q * half
        At = QT * (adj_T + wp.transpose(adj_T)) * Q * half
        # eigenvalue part: tau_i = 2 mu alpha e_i + kappa tr, p_i = exp(beta e_i)
        t_bar = vec3(At[0, 0], At[1, 1], At[2, 2])
        p_bar = vec3(Ap[0, 0], Ap[1, 1], Ap[2, 2])
        sum_t = t_bar[0] + t_bar[1] + t_bar[2]
        alpha_bar = scalar(2.0) * mu * wp.dot(t_bar, e) + wp.dot(p_bar, wp.cw_mul(p, e))
        e_bar = scalar(2.0) * mu * alpha * t_bar + beta * wp.cw_mul(p_bar, p)
        tr_bar = kappa * sum_t
        mu_bar = scalar(2.0) * alpha * wp.dot(t_bar, e) + scalar(2.0 / 3.0) * tr * sum_t
        lam_bar = tr * sum_t
        tau_y_bar = zero
        K_bar = zero
        n_bar = zero
        if t_trial > tau_y:
            t_new = alpha * t_trial
            t_new_bar = alpha_bar / t_trial
            t_trial_bar = -alpha_bar * t_new / (t_trial * t_trial)
            tau_y_bar = t_new_bar
            u = t_new - tau_y
            if model == MODEL_HERSCHEL_BULKLEY and u > zero:
                relax = mu * dt
                m = one / n
                q = wp.pow(u / K, m)
                s = t_new_bar / (one + relax * m * q / u)
                t_trial_bar += s
                tau_y_bar -= s
                mu_bar -= s * q * dt
                K_bar = s * relax * m * q / K
                n_bar = s * relax * q * wp.log(u / K) * m * m
            mu_bar += t_trial_bar * sqrt2 * r
            e_bar += (t_trial_bar * sqrt2 * mu / r) * e
        mean_e_bar = third * (e_bar[0] + e_bar[1] + e_bar[2])
        M = mat33()
        for i in range(3):
            for j in range(3):
                if i == j:
                    M[i, i] = (e_bar[i] - mean_e_bar + tr_bar) * half / l[i]
                else:
                    ld = log_divided(l[i], l[j])
                    M[i, j] = At[i, j] * mu * alpha * ld + Ap[i, j] * exp_divided(beta * e[i], beta * e[j]) * beta \
                        * half * ld
        wp.adjoint[b] += Q * M * QT
        wp.adjoint[mu] += mu_bar
        wp.adjoint[lam] += lam_bar
        wp.adjoint[tau_y] += tau_y_bar
        wp.adjoint[K] += K_bar
        wp.adjoint[n] += n_bar

    @wp.func
    def yield_factor(structure: wp.array(dtype=scalar), p: int, thixotropy: scalar, floor: scalar) -> scalar:
        """floor + (1 - floor) exp(-thixotropy xi): how much of the yield stress a particle's structure keeps after
        accumulating the structure measure xi (``structure_update``; 1 when the material is not thixotropic)."""
        factor = one
        if thixotropy > zero:
            factor = floor + (one - floor) * wp.exp(-thixotropy * structure[p])
        return factor

    @wp.func
    def constitutive(F: mat33, C: mat33, mat: wp.array(dtype=scalar), model: int, dt: scalar, Q: mat33, l: vec3,
                     tau_y_factor: scalar):
        """Trial deformation, plastic return and Kirchhoff stress, the yield stress scaled by ``tau_y_factor`` (1
        but for a thixotropic material's broken-down structure). Returns (F_new, tau)."""
        I = wp.identity(3, dtype=scalar)
        Ft = (I + dt * C) * F
        mu = mat[P_MU]
        lam = mat[P_LAM]
        F_new = Ft
        tau = mat33()
        if model == MODEL_NEWTONIAN:
            # Volume tracked through J only; viscous stress from the APIC velocity gradient C.
            J = wp.determinant(Ft)
            cbrt = wp.pow(J, third)
            F_new = wp.diag(vec3(cbrt, cbrt, cbrt))
            D = half * (C + wp.transpose(C))
            dev_D = D - third * wp.trace(D) * I
            tau = J * scalar(2.0) * mat[P_K] * dev_D + lam * wp.log(J) * I
        elif model == MODEL_NEO_HOOKEAN:
            J = wp.determinant(Ft)
            tau = mu * (Ft * wp.transpose(Ft) - I) + lam * wp.log(J) * I
        else:
            # Hencky strain; von Mises yield on the equivalent shear stress |s| / sqrt(2).
            PT = hencky_return(Ft * wp.transpose(Ft), Q, l, mu, lam, mat[P_TAU_Y] * tau_y_factor, mat[P_K], mat[P_N],
                               dt, model)
            P = mat33(PT[0, 0], PT[0, 1], PT[0, 2], PT[1, 0], PT[1, 1], PT[1, 2], PT[2, 0], PT[2, 1], PT[2, 2])
            tau = mat33(PT[3, 0], PT[3, 1], PT[3, 2], PT[4, 0], PT[4, 1], PT[4, 2], PT[5, 0], PT[5, 1], PT[5, 2])
            F_new = P * Ft
        return F_new, tau

    @wp.kernel
    def return_mapping(F: wp.array(dtype=mat33), C: wp.array(dtype=mat33), mat: wp.array(dtype=scalar),
                       model: int, dt: scalar, structure: wp.array(dtype=scalar), thixotropy: scalar,
                       thixotropy_floor: scalar, F_out: wp.array(dtype=mat33), tau_out: wp.array(dtype=mat33)):
        """The constitutive update alone, for tests and diagnostics."""
        p = wp.tid()
        Ft = (wp.identity(3, dtype=scalar) + dt * C[p]) * F[p]
        Q, l = eigen(Ft * wp.transpose(Ft), wp.identity(3, dtype=scalar))
        F_new, tau = constitutive(F[p], C[p], mat, model, dt, Q, l,
                                  yield_factor(structure, p, thixotropy, thixotropy_floor))
        F_out[p] = F_new
        tau_out[p] = tau

    @wp.kernel
    def eigen_kernel(F: wp.array(dtype=mat33), C: wp.array(dtype=mat33), dt: scalar, guess: wp.array(dtype=mat33),
                     q_out: wp.array(dtype=mat33), l_out: wp.array(dtype=vec3)):
        """Eigen-decomposition of the trial b = Ft Ft^T for the Hencky models, from the basis ``guess`` (the last
        step's; ``q_out`` itself may be passed); launched outside the tape."""
        p = wp.tid()
        Ft = (wp.identity(3, dtype=scalar) + dt * C[p]) * F[p]
        Q, l = eigen(Ft * wp.transpose(Ft), guess[p])
        q_out[p] = Q
        l_out[p] = l

    @wp.kernel
    def structure_update(F: wp.array(dtype=mat33), C: wp.array(dtype=mat33), eig_l: wp.array(dtype=vec3),
                         mat: wp.array(dtype=scalar), model: int, dt: scalar, thixotropy: scalar,
                         thixotropy_floor: scalar, thixotropy_exponent: scalar, structure: wp.array(dtype=scalar),
                         structure_out: wp.array(dtype=scalar)):
        """A thixotropic particle's structure measure, the integral of its plastic shear rate to the power
        ``thixotropy_exponent`` over time: with 1 the plastic shear strain (the step's return mapping takes the
        trial deviatoric Hencky strain e to alpha e, a plastic shear strain sqrt(2) (1 - alpha) |e|, gamma in
        simple shear), with 0 the time it has spent yielding."""
        p = wp.tid()
        l = eig_l[p]
        eps = half * vec3(wp.log(l[0]), wp.log(l[1]), wp.log(l[2]))
        e = eps - vec3(third * (eps[0] + eps[1] + eps[2]))
        tau_y = mat[P_TAU_Y] * yield_factor(structure, p, thixotropy, thixotropy_floor)
        alpha = yield_scale(e, mat[P_MU], tau_y, mat[P_K], mat[P_N], dt, model)
        plastic = sqrt2 * (one - alpha) * wp.sqrt(wp.dot(e, e))
        if thixotropy_exponent != one and plastic > zero:
            plastic = dt * wp.pow(plastic / dt, thixotropy_exponent)
        structure_out[p] = structure[p] + plastic

    @wp.kernel
    def hb_excess_kernel(trial: wp.array(dtype=scalar), relax: scalar, K: scalar, n: scalar,
                         out: wp.array(dtype=scalar)):
        i = wp.tid()
        out[i] = hb_excess(trial[i], relax, K, n)

    @wp.func
    def stencil(x: vec3, inv_dx: scalar, n: int):
        # Clamped so that a runaway particle (flagged by g2p) never indexes outside the grid.
        base_f = x * inv_dx - vec3(half, half, half)
        base = wp.vec3i(wp.clamp(int(wp.floor(base_f[0])), 0, n - 3), wp.clamp(int(wp.floor(base_f[1])), 0, n - 3),
                        wp.clamp(int(wp.floor(base_f[2])), 0, n - 3))
        fx = x * inv_dx - vec3(scalar(base[0]), scalar(base[1]), scalar(base[2]))
        w0 = half * wp.cw_mul(vec3(scalar(1.5)) - fx, vec3(scalar(1.5)) - fx)
        d1 = fx - vec3(one)
        w1 = vec3(scalar(0.75)) - wp.cw_mul(d1, d1)
        d2 = fx - vec3(half)
        w2 = half * wp.cw_mul(d2, d2)
        # row = node offset along an axis, column = axis
        return base, fx, mat33(w0[0], w0[1], w0[2], w1[0], w1[1], w1[2], w2[0], w2[1], w2[2])

    @wp.func
    def node_offset(i: int, j: int, k: int) -> vec3:
        # A function, so that unrolled loop constants are not cast in place (Warp types them once).
        return vec3(scalar(i), scalar(j), scalar(k))

    @wp.kernel
    def p2g(x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), C: wp.array(dtype=mat33),
            F: wp.array(dtype=mat33), mat: wp.array(dtype=scalar), model: int, p_vol: scalar, dt: scalar,
            inv_dx: scalar, eig_q: wp.array(dtype=mat33), eig_l: wp.array(dtype=vec3),
            structure: wp.array(dtype=scalar), thixotropy: scalar, thixotropy_floor: scalar, transfer: int,
            F_out: wp.array(dtype=mat33), grid_m: wp.array3d(dtype=scalar), grid_mv: wp.array3d(dtype=vec3)):
        """The constitutive update and the stress' impulse on the grid, and with ``transfer`` the particles' mass and
        momentum too (else ``C`` is the grid's velocity gradient at particles held in place, ``v`` unread)."""
        p = wp.tid()
        Cp = C[p]
        F_new, tau = constitutive(F[p], Cp, mat, model, dt, eig_q[p], eig_l[p],
                                  yield_factor(structure, p, thixotropy, thixotropy_floor))
        F_out[p] = F_new
        p_mass = mat[P_RHO] * p_vol
        affine = (-dt * p_vol * scalar(4.0) * inv_dx * inv_dx) * tau
        mv = vec3()
        if transfer != 0:
            affine = affine + p_mass * Cp
            mv = p_mass * v[p]
        base, fx, W = stencil(x[p], inv_dx, grid_m.shape[0])
        dx = one / inv_dx
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    wgt = W[i, 0] * W[j, 1] * W[k, 2]
                    dpos = (node_offset(i, j, k) - fx) * dx
                    gi = base[0] + i
                    gj = base[1] + j
                    gk = base[2] + k
                    wp.atomic_add(grid_mv, gi, gj, gk, wgt * (mv + affine * dpos))
                    if transfer != 0:
                        wp.atomic_add(grid_m, gi, gj, gk, wgt * p_mass)

    @wp.func
    def interpolate(x: vec3, grid_v: wp.array3d(dtype=vec3), inv_dx: scalar):
        """The grid velocity at ``x`` and its gradient there (APIC's affine velocity)."""
        base, fx, W = stencil(x, inv_dx, grid_v.shape[0])
        dx = one / inv_dx
        new_v = vec3()
        new_C = mat33()
        for di in range(3):
            for dj in range(3):
                for dk in range(3):
                    gv = grid_v[base[0] + di, base[1] + dj, base[2] + dk]
                    wgt = W[di, 0] * W[dj, 1] * W[dk, 2]
                    dpos = (node_offset(di, dj, dk) - fx) * dx
                    new_v += wgt * gv
                    new_C += (scalar(4.0) * inv_dx * inv_dx * wgt) * wp.outer(gv, dpos)
        return new_v, new_C

    @wp.kernel
    def grid_gradient(x: wp.array(dtype=vec3), grid_v: wp.array3d(dtype=vec3), inv_dx: scalar,
                      C_out: wp.array(dtype=mat33)):
        """The grid velocity's gradient at each particle (as ``g2p`` gives it, without the transfer)."""
        p = wp.tid()
        _velocity, gradient = interpolate(x[p], grid_v, inv_dx)
        C_out[p] = gradient

    @wp.kernel
    def add_momentum(grid_m: wp.array3d(dtype=scalar), grid_v: wp.array3d(dtype=vec3), offset: wp.vec3i,
                     grid_mv: wp.array3d(dtype=vec3)):
        """Adds the nodes' momentum (mass times velocity) to ``grid_mv``, over a box of nodes from ``offset``."""
        i, j, k = wp.tid()
        i += offset[0]
        j += offset[1]
        k += offset[2]
        grid_mv[i, j, k] = grid_mv[i, j, k] + grid_m[i, j, k] * grid_v[i, j, k]

    @wp.func
    def cup_sdf(p: vec3, g: wp.array2d(dtype=scalar), c: int) -> scalar:
        # Shell of thickness g[c, 6] around a truncated-cone cavity with vertical axis at (x, z) = (g[c, 0], g[c, 1]),
        # open rim at y = g[c, 2], height g[c, 3], inner radius g[c, 4] at the rim and g[c, 5] at the closed top.
        r = wp.sqrt((p[0] - g[c, 0]) * (p[0] - g[c, 0]) + (p[2] - g[c, 1]) * (p[2] - g[c, 1]))
        h = p[1] - g[c, 2]
        height = g[c, 3]
        r_in = g[c, 4] + (g[c, 5] - g[c, 4]) * wp.clamp(h / height, zero, one)
        cavity = wp.max(r - r_in, h - height)  # < 0 inside the cavity
        thickness = g[c, 6]
        return wp.max(wp.abs(cavity - half * thickness) - half * thickness, -h)

    @wp.func
    def box_sdf(p: vec3, g: wp.array2d(dtype=scalar), c: int) -> scalar:
        q = vec3(wp.abs(p[0] - g[c, 0]) - g[c, 3], wp.abs(p[1] - g[c, 1]) - g[c, 4],
                 wp.abs(p[2] - g[c, 2]) - g[c, 5])
        outside = wp.length(vec3(wp.max(q[0], zero), wp.max(q[1], zero), wp.max(q[2], zero)))
        return outside + wp.min(wp.max(q[0], wp.max(q[1], q[2])), zero)

    @wp.func
    def shape_sdf(shape: int, p: vec3, g: wp.array2d(dtype=scalar), c: int) -> scalar:
        if shape == SHAPE_FLOOR:
            return p[1] - g[c, 0]
        if shape == SHAPE_BOX:
            return box_sdf(p, g, c)
        return cup_sdf(p, g, c)

    @wp.func
    def shape_normal(shape: int, p: vec3, g: wp.array2d(dtype=scalar), c: int, h: scalar) -> vec3:
        if shape == SHAPE_FLOOR:
            return vec3(zero, one, zero)
        grad = vec3(
            shape_sdf(shape, p + vec3(h, zero, zero), g, c) - shape_sdf(shape, p - vec3(h, zero, zero), g, c),
            shape_sdf(shape, p + vec3(zero, h, zero), g, c) - shape_sdf(shape, p - vec3(zero, h, zero), g, c),
            shape_sdf(shape, p + vec3(zero, zero, h), g, c) - shape_sdf(shape, p - vec3(zero, zero, h), g, c))
        return grad / wp.max(wp.length(grad), tiny)

    @wp.func
    def contact(v: vec3, v_col: vec3, nrm: vec3, law: int, friction: scalar, keep: scalar) -> vec3:
        # ``keep``: the share of the tangential velocity a Navier wall leaves at the node after its traction
        rel = v - v_col
        if law == CONTACT_STICKY:
            return v_col
        vn = wp.dot(rel, nrm)
        if law == CONTACT_NAVIER:
            return keep * (rel - vn * nrm) + wp.max(vn, zero) * nrm + v_col
        if vn >= zero:
            return v
        vt = rel - vn * nrm
        if law == CONTACT_SLIP:
            return vt + v_col
        vt_norm = wp.sqrt(wp.dot(vt, vt) + tiny)
        return wp.max(one + friction * vn / vt_norm, zero) * vt + v_col

    @wp.func
    def adhere(v: vec3, v_col: vec3, cut: scalar) -> vec3:
        """The velocity relative to a wall slowed by ``cut`` (to rest at most): a traction that holds the material
        against sliding and separating alike, whatever the pressure."""
        rel = v - v_col
        speed = wp.sqrt(wp.dot(rel, rel) + tiny)
        return v_col + wp.max(one - cut / speed, zero) * rel

    @wp.func
    def collider_frame(node: vec3, time: scalar, c: int, timing: wp.array2d(dtype=scalar),
                       bparams: wp.array2d(dtype=scalar)) -> vec3:
        """``node`` in collider c's own frame: moved back by how far the collider has travelled by ``time``."""
        vel = vec3(bparams[c, B_VX], bparams[c, B_VY], bparams[c, B_VZ])
        return node - (wp.clamp(time, timing[c, 0], timing[c, 1]) - timing[c, 0]) * vel

    @wp.func
    def collide(v: vec3, node: vec3, m: scalar, time: scalar, dt: scalar, dx: scalar, c: int,
                shapes: wp.array(dtype=int), laws: wp.array(dtype=int), geom: wp.array2d(dtype=scalar),
                timing: wp.array2d(dtype=scalar), bparams: wp.array2d(dtype=scalar), adhesion_cut: scalar,
                face_mass: scalar) -> vec3:
        # Collider c moves with velocity bparams[c, 1:4] between timing[c, 0] and timing[c, 1]; a non-sticky one
        # slows the material within a cell of its face by ``adhesion_cut`` (m/s) when the walls adhere: an adhesion
        # A (Pa) on a layer of a cell's thickness, A dt / (rho dx). A Navier wall's traction beta v_slip (beta =
        # bparams[c, B_FRICTION], Pa s/m) acts, implicitly, on the nodes of its face: dx^2 of wall each, in full
        # where the node holds the ``face_mass`` material on one side of a face gives it, else in proportion.
        vel = vec3(bparams[c, B_VX], bparams[c, B_VY], bparams[c, B_VZ])
        v_col = vec3()
        if time >= timing[c, 0] and time < timing[c, 1]:
            v_col = vel
        local = collider_frame(node, time, c, timing, bparams)
        out = v
        sdf = shape_sdf(shapes[c], local, geom, c)
        if sdf <= zero:
            nrm = shape_normal(shapes[c], local, geom, c, half * dx)
            keep = one
            if laws[c] == CONTACT_NAVIER and sdf > -scalar(NAVIER_LAYER) * dx:
                keep = one / (one + bparams[c, B_FRICTION] * dx * dx * dt / wp.max(m, face_mass))
            out = contact(v, v_col, nrm, laws[c], bparams[c, B_FRICTION], keep)
        # adhesion on the nodes within a cell of the wall's face
        if adhesion_cut > zero and laws[c] != CONTACT_STICKY and wp.abs(sdf) < dx:
            out = adhere(out, v_col, adhesion_cut)
        return out

    @wp.kernel
    def grid_update(grid_m: wp.array3d(dtype=scalar), grid_mv: wp.array3d(dtype=vec3), dt: scalar,
                    time: scalar, dx: scalar, gravity: vec3, shapes: wp.array(dtype=int),
                    laws: wp.array(dtype=int), geom: wp.array2d(dtype=scalar), timing: wp.array2d(dtype=scalar),
                    bparams: wp.array2d(dtype=scalar), min_mass: scalar, offset: wp.vec3i, adhesion_cut: scalar,
                    air_drag: scalar, face_mass: scalar, open_drag: vec4, open_floor: scalar, open_layer: scalar,
                    open_span: scalar, grid_v: wp.array3d(dtype=vec3)):
        # launched over the box of nodes the particles reach, from node ``offset``
        i, j, k = wp.tid()
        i += offset[0]
        j += offset[1]
        k += offset[2]
        m = grid_m[i, j, k]
        if m <= min_mass:  # empty, or touched only by a weight's rounding error (whose adjoint 1/m^2 overflows)
            grid_v[i, j, k] = vec3()
            return
        v = grid_mv[i, j, k] / m + dt * gravity
        if air_drag > zero:  # quadratic drag, implicit: stable at any step
            v = v / (one + dt * air_drag * wp.length(v))
        node = vec3(scalar(i), scalar(j), scalar(k)) * dx
        if open_span > zero:  # the generic discrepancy's linear drag (a span of 0: none), implicit
            late = wp.min(time / open_span, one)
            floor = wp.exp(-wp.max(node[1] - open_floor, zero) / open_layer)
            rate = floor * ((one - late) * open_drag[0] + late * open_drag[1]) \
                + (one - floor) * ((one - late) * open_drag[2] + late * open_drag[3])
            v = v / (one + dt * wp.max(rate, -half / dt))  # a driving rate at most doubles v per step
        count = shapes.shape[0]
        for c in range(MAX_COLLIDERS):  # unrolled: Warp differentiates static loops only
            if c < count:
                v = collide(v, node, m, time, dt, dx, c, shapes, laws, geom, timing, bparams, adhesion_cut,
                            face_mass)
        # Domain faces are slip walls.
        n = grid_m.shape[0]
        lo = wp.vec3i(i, j, k)
        keep = vec3(one, one, one)
        for a in range(3):
            if (lo[a] < BOUND and v[a] < zero) or (lo[a] > n - BOUND and v[a] > zero):
                keep[a] = zero
        grid_v[i, j, k] = wp.cw_mul(v, keep)

    @wp.kernel
    def capillary_stress(grid_m: wp.array3d(dtype=scalar), inv_full_mass: scalar, surface_tension: scalar,
                         time: scalar, dx: scalar, shapes: wp.array(dtype=int), geom: wp.array2d(dtype=scalar),
                         timing: wp.array2d(dtype=scalar), bparams: wp.array2d(dtype=scalar), offset: wp.vec3i,
                         cell_stress: wp.array3d(dtype=mat33)):
        """The capillary stress gamma (|g| I - g g^T / |g|) of the continuum surface stress model in each cell (index
        of its lowest node, from ``offset``), g the gradient at the cell's centre of the material's volume fraction
        (node mass / ``1 / inv_full_mass``, trilinear); zero in cells that touch a collider (neutral walls)."""
        i, j, k = wp.tid()
        i += offset[0]
        j += offset[1]
        k += offset[2]
        g = vec3()
        solid = int(0)  # noqa: UP018, RUF046 (a variable for Warp, not a constant)
        count = shapes.shape[0]
        for a in range(2):
            for b in range(2):
                for d in range(2):
                    corner = node_offset(a, b, d)
                    fraction = grid_m[i + a, j + b, k + d] * inv_full_mass
                    g += fraction * (scalar(2.0) * corner - vec3(one, one, one))
                    node = (vec3(scalar(i), scalar(j), scalar(k)) + corner) * dx
                    for c in range(MAX_COLLIDERS):
                        if c < count:
                            local = collider_frame(node, time, c, timing, bparams)
                            if shape_sdf(shapes[c], local, geom, c) <= zero:
                                solid = 1
        g = g * (scalar(0.25) / dx)
        size = wp.length(g)
        stress = mat33()
        if solid == 0 and size > tiny:
            stress = surface_tension * (size * wp.identity(n=3, dtype=scalar) - wp.outer(g, g) / size)
        cell_stress[i, j, k] = stress

    @wp.kernel
    def capillary_force(cell_stress: wp.array3d(dtype=mat33), dt: scalar, dx: scalar, offset: wp.vec3i,
                        grid_mv: wp.array3d(dtype=vec3)):
        """Adds to each node's momentum the impulse of the cells' capillary stress around it over the step:
        -sum over its cells of dx^3 stress grad N (N the node's trilinear shape function, at the cell's centre)."""
        i, j, k = wp.tid()
        i += offset[0]
        j += offset[1]
        k += offset[2]
        force = vec3()
        for a in range(2):
            for b in range(2):
                for d in range(2):
                    side = scalar(2.0) * node_offset(a, b, d) - vec3(one, one, one)
                    force += cell_stress[i - 1 + a, j - 1 + b, k - 1 + d] * side
        grid_mv[i, j, k] = grid_mv[i, j, k] + (scalar(0.25) * dt * dx * dx) * force

    @wp.kernel
    def reached_nodes(x: wp.array(dtype=vec3), inv_dx: scalar, n: int, bounds: wp.array(dtype=int)):
        """The box of grid nodes the particles' stencils reach: bounds[0:3] lowest, bounds[3:6] highest index (to be
        set beforehand to the grid's size and -1)."""
        p = wp.tid()
        base, _fraction, _weights = stencil(x[p], inv_dx, n)
        for a in range(3):
            wp.atomic_min(bounds, a, base[a])
            wp.atomic_max(bounds, 3 + a, base[a] + 2)

    @wp.kernel
    def mirror_fold(grid_m: wp.array3d(dtype=scalar), grid_mv: wp.array3d(dtype=vec3), plane: int, mass: int):
        """Makes the grid that of a flow symmetric about the node plane z = ``plane`` from particles on one side:
        node pairs at ``plane`` -/+ d each add the other's z-reflected momentum and, if ``mass``, mass (what the
        particles' mirror images deposit); the plane's own nodes double."""
        i, j, d = wp.tid()
        a = plane + d
        b = plane - d
        flip = vec3(one, one, -one)
        mv_a = grid_mv[i, j, a]
        mv_b = grid_mv[i, j, b]
        if d == 0:
            if mass != 0:
                grid_m[i, j, a] = scalar(2.0) * grid_m[i, j, a]
            grid_mv[i, j, a] = mv_a + wp.cw_mul(flip, mv_a)
        else:
            if mass != 0:
                m = grid_m[i, j, a] + grid_m[i, j, b]
                grid_m[i, j, a] = m
                grid_m[i, j, b] = m
            grid_mv[i, j, a] = mv_a + wp.cw_mul(flip, mv_b)
            grid_mv[i, j, b] = mv_b + wp.cw_mul(flip, mv_a)

    @wp.kernel
    def g2p(x: wp.array(dtype=vec3), grid_v: wp.array3d(dtype=vec3), dt: scalar, inv_dx: scalar,
            x_out: wp.array(dtype=vec3), v_out: wp.array(dtype=vec3), C_out: wp.array(dtype=mat33),
            unstable: wp.array(dtype=int)):
        p = wp.tid()
        new_v, new_C = interpolate(x[p], grid_v, inv_dx)
        dx = one / inv_dx
        step = dt * wp.length(new_v)
        if not (step <= dx):  # also catches NaN
            wp.atomic_max(unstable, 0, 1)
        v_out[p] = new_v
        C_out[p] = new_C
        x_out[p] = x[p] + dt * new_v

    return SimpleNamespace(vec3=vec3, vec4=vec4, mat33=mat33, eigen=eigen_kernel, structure_update=structure_update,
                           p2g=p2g, reached_nodes=reached_nodes, mirror_fold=mirror_fold, grid_update=grid_update,
                           g2p=g2p, grid_gradient=grid_gradient, add_momentum=add_momentum,
                           capillary_stress=capillary_stress, capillary_force=capillary_force,
                           return_mapping=return_mapping, hb_excess=hb_excess_kernel)


def scalar_type(dtype) -> type:
    """The Warp scalar type of a torch dtype."""
    import torch

    if dtype == torch.float64:
        return wp.float64
    if dtype == torch.float32:
        return wp.float32
    raise ValueError(f"unsupported dtype {dtype}: use torch.float32 or torch.float64")
