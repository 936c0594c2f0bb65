"""Perturbation oracle for the two-mesh idler of Liu (2007), Ch. 3 (issue 16, item 4).

G. Liu, *Nonlinear Dynamics of Multi-Mesh Gear Systems*, PhD thesis, Ohio State, 2007,
Chapter 3 "Nonlinear dynamics of idler gear systems" (= Liu & Parker, Nonlinear Dynamics).
Written from the thesis text (`shared/seeds/000_*.txt`) and the notes
`shared/reference/models-liu-parker-2007.md` (§0 conventions, §2 Ch. 3, §8 errata); numpy
only, nothing from geardyn.  Equation numbers are the thesis'.

Model (eqs. 3.1-3.2, 3.9-3.12)
------------------------------
Three rigid gears (pinion 1, idler 2, gear 3), torsional only, rigid bearings, two meshes.
`u_i = r_i θ_i`, `m_i = I_i/r_i²`, DTEs `x_1 = u_1 + u_2`, `x_2 = −u_2 − u_3`:

    M ẍ + C ẋ + diag(H_1 k_1(t), H_2 k_2(t)) x = [T, T]ᵀ,   H_j = [1 + sgn x_j]/2   (3.1)
    M = 1/Σm [[(m_2+m_3)m_1, m_1m_3], [m_1m_3, (m_1+m_2)m_3]]                          (3.2)

Dimensionless with ω_1 (first natural frequency of the mean system) and x̄_1 = T/k̄_1:
τ = ω_1 t, ω = ω̃/ω_1 (mesh), y_j = x_j/x̄_1, c = ω_2/ω_1, λ = k̄_2/k̄_1 (3.9);
M̂ ÿ + Ĉ ẏ + K̂ y = [1, 1]ᵀ, M̂ = ω_1² M/k̄_1, K̂ = diag(H_1 k_1, H_2 k_2)/k̄_1 (3.10);
mean modes (c_l² M̂ − K̂_mean) s_l = 0, Sᵀ M̂ S = I, modal damping 2Γc_l q̇_l (3.11), i.e.
Ĉ = M̂ S diag(2Γc_l) Sᵀ M̂.  Modal forces F_l = Σ_n s_nl / c_l², mean DTEs
C_j = s_j1 F_1 + s_j2 F_2 (= 1 and 1/λ).

Mesh stiffness (3.12)-(3.13): complex Fourier convention k = k̄ + Σ (k̃_m e^{imωτ} + c.c.),
ε = 2|κ̃_1|/k̄_1 (first-harmonic cosine amplitude over the mean: *not* the peak-to-peak ratio of
Ch. 2/4).  Rectangular waves: the number of pairs drops at the phase reference s = 0, low
stiffness on s ∈ [0, 2 − ς), high on [2 − ς, 1) (for 1 < ς < 2), peak-to-peak Λ_j; mesh 2
leads mesh 1 by φ (rad).  This is the wave of geardyn's docs/model.md `rectangular` kind, so
the scene's `phase = φ/2π` (mesh cycles) is the same φ.

Conventions of this module
--------------------------
* The mode shapes are signed so that s_11 > 0 and s_12 > 0 (the notes print s_1 with both
  entries negative; only sign-invariant combinations enter the results).
* `eta(m)` returns η̃_m/k̄_1 (not /k̄_2): λ η̃_m/k̄_2 = η̃_m/k̄_1 is how λ enters (3.32)/(3.36)/(3.45).
* Both meshes default to the same peak-to-peak ratio ε_pp (relative to their own means), so
  Λ_2/Λ_1 = λ.  For ς = 1.5, |κ̃_1|/k̄ = ε_pp/π, i.e. ε = 2ε_pp/π.

Errata applied (notes §8 item 8 and §2.4-2.6 [R]), each marked where used:
* (3.15): the mean term h_0 of the separation function is counted once.
* (3.32)/(3.36): R_2 and Q_2 use |s_jr| (h_1 changes sign with s_jr, eq. 3.16); with it the
  backbone is ω = c_r − Σ_j λ_j s_jr² (θ_j − sinθ_j cosθ_j)/(2π c_r) (λ_1 = 1, λ_2 = λ).
* (3.30): θ_j = arccos(C_j/(2|s_jr|α)) for 2|s_jr|α > C_j, else 0 (the printed two-case form
  is the same function).
* (3.35): the linear boundaries of the subharmonic are 2c_r ± √(|Q_3|² − 4Γ²c_r⁴)/c_r (printed
  "c_r ±").
* (3.43): lacks 1/c_r² on the first term; `onset_linear` uses (3.33), which it equals for c_r = 1.
* (3.27): R̂_4 = s_1r²κ_2 + λ s_2r²η_2 (the printed one copies R̂_3); used in `response_two_harmonics`.
* (3.41): prefactor 1/(4αc_r) (as in 3.37), and W built with the actual first-order response
  amplitudes (κ̃_1/k̄_1 instead of the normalised κ_1 in B_l) so that W carries its order ε².
"""

import math

import numpy as np

# Table 3.1 (notes §2.9) with the errata of notes §8 item 7: gear inertia 0.119 kg m² (printed
# 1.19e-2) and λ = k̄_2/k̄_1 = 1.08 (not in Table 3.1; the value of Ch. 4 / Table 2.1), which give
# c = ω_2/ω_1 = 2.762 against the table's 2.76.  k̄_1 = 2.98e8 N/m (Table 2.1, same gears).
TABLE_3_1 = dict(
    teeth=(38, 55, 94),
    module=2.54e-3,
    base_radius=(0.04535, 0.06564, 0.1122),
    inertia=(2.62e-3, 3.27e-3, 0.119),
    k1_mean=2.98e8,
    lam=1.08,
    phi=0.0,
    gamma=0.04,
    contact_ratio=(1.5, 1.5),
    c_printed=2.76,
)


# ----------------------------------------------------------------------------------------------
# Mesh stiffness harmonics (3.12)-(3.13)
# ----------------------------------------------------------------------------------------------

def rectangular_harmonic(m, contact_ratio, pp_ratio, phase=0.0):
    """k̃_m/k̄ of the rectangular wave, computed in the time domain (notes §2.3: "define k(t) in
    the time domain").  Wave: low on s ∈ [0, 1−f), high on [1−f, 1), f = ς − ⌊ς⌋, p-p ratio
    ε_pp; `phase` (rad) is a lead: k(τ) = k_0(ωτ + phase).  Returns the complex coefficient of
    e^{imωτ}:  ε_pp sin(mπf) e^{imπf} e^{im·phase}/(mπ)  (= ε_pp sin(mπς) e^{imπς}.../(mπ)).

    The printed (3.13) is −ε_pp sin(mπς) e^{−im(πς − φ)}/(mπ): same magnitude; the relative
    phase of the two meshes' first harmonics is φ + π(ς_2 − ς_1) here and φ + π(ς_1 − ς_2) in
    print, i.e. the print's φ is this −φ when ς_1 ≠ ς_2 (notes §2.3 [R], §8 item 12)."""
    f = contact_ratio - math.floor(contact_ratio)
    return pp_ratio * math.sin(m * math.pi * f) * np.exp(1j * m * (math.pi * f + phase)) / (m * math.pi)


def rectangular_harmonic_printed(m, contact_ratio, pp_ratio, phi=0.0):
    """The printed (3.13): κ̃_m = −(Λ/(mπ)) sin(mπς) e^{−im(πς − φ)} (per unit mean)."""
    return -pp_ratio / (m * math.pi) * math.sin(m * math.pi * contact_ratio) * np.exp(
        -1j * m * (math.pi * contact_ratio - phi))


def eps_from_pp(pp_ratio, contact_ratio):
    """Ch. 3's ε = 2|κ̃_1|/k̄ of a rectangular wave with peak-to-peak ratio ε_pp (3.12)."""
    return 2.0 * pp_ratio * abs(math.sin(math.pi * contact_ratio)) / math.pi


def pp_from_eps(eps, contact_ratio):
    """Inverse of `eps_from_pp`: ε_pp = πε/(2|sin πς|) (= πε/2 for ς = 1.5)."""
    s = abs(math.sin(math.pi * contact_ratio))
    if s < 1e-12:
        raise ValueError(f"contact ratio {contact_ratio}: integer, the first harmonic vanishes")
    return math.pi * eps / (2.0 * s)


# ----------------------------------------------------------------------------------------------
# The system
# ----------------------------------------------------------------------------------------------

class IdlerCh3:
    """The Ch. 3 idler with Table 3.1 data (defaults) and first-order perturbation results.

    eps: Ch. 3's ε = 2|κ̃_1|/k̄_1 (3.12).  gamma: modal damping ratio Γ (3.11).
    phi: mesh phase (rad, mesh 2 leads).  pp_ratio: optional (ε_pp1, ε_pp2) instead of eps
    (then eps is derived from ε_pp1).  torque: pinion torque T_1, N m (T = T_1/r_1).
    """

    def __init__(self, eps=0.2, gamma=TABLE_3_1["gamma"], phi=TABLE_3_1["phi"],
                 contact_ratio=TABLE_3_1["contact_ratio"], pp_ratio=None,
                 inertia=TABLE_3_1["inertia"], base_radius=TABLE_3_1["base_radius"],
                 teeth=TABLE_3_1["teeth"], k1_mean=TABLE_3_1["k1_mean"], lam=TABLE_3_1["lam"],
                 torque=100.0):
        self.gamma = float(gamma)
        self.phi = float(phi)
        self.contact_ratio = tuple(float(c) for c in contact_ratio)
        if pp_ratio is None:
            e = pp_from_eps(eps, self.contact_ratio[0])
            pp_ratio = (e, e)
        self.pp_ratio = tuple(float(p) for p in pp_ratio)
        self.eps = eps_from_pp(self.pp_ratio[0], self.contact_ratio[0])
        self.inertia = tuple(inertia)
        self.base_radius = tuple(base_radius)
        self.teeth = tuple(teeth)
        self.k1_mean = float(k1_mean)
        self.lam = float(lam)
        self.torque = float(torque)

        # (3.2): equivalent masses, M, Q.
        m = np.array([i / r ** 2 for i, r in zip(self.inertia, self.base_radius)])
        self.m = m
        s = m.sum()
        self.M = np.array([[(m[1] + m[2]) * m[0], m[0] * m[2]],
                           [m[0] * m[2], (m[0] + m[1]) * m[2]]]) / s
        self.Q = np.array([[m[1] + m[2], m[2]], [m[0], -m[2]], [-m[0], -m[0] - m[1]]]) / s
        self.K_mean = np.diag([self.k1_mean, self.lam * self.k1_mean])
        self.mesh_force = self.torque / self.base_radius[0]      # T = T_1/r_1
        self.x1bar = self.mesh_force / self.k1_mean              # mean STE of mesh 1
        # Dimensional natural frequencies of the mean system (rad/s).
        w2 = np.sort(np.linalg.eigvals(np.linalg.solve(self.M, self.K_mean)).real)
        self.omega_nat = np.sqrt(w2)
        self.omega_1 = float(self.omega_nat[0])
        # (3.10): M̂ = ω_1² x̄_1 M/T = ω_1² M/k̄_1, K̂_mean = diag(1, λ).
        self.Mhat = self.omega_1 ** 2 * self.M / self.k1_mean
        self.Khat = np.diag([1.0, self.lam])
        c2, S = _mass_normalised_modes(self.Khat, self.Mhat)
        self.c = np.sqrt(c2)              # c_1 = 1, c_2 = c
        self.S = S                        # columns s_l, Sᵀ M̂ S = I, S[0, l] > 0
        # (3.11): modal forces and mean DTEs C_j (= 1, 1/λ).
        self.F = S.sum(axis=0) / self.c ** 2
        self.C = S @ self.F
        self.Chat = self.Mhat @ S @ np.diag(2 * self.gamma * self.c) @ S.T @ self.Mhat

    # -- parameters -----------------------------------------------------------------------------
    @property
    def c_ratio(self):
        """c = ω_2/ω_1 (3.9); Table 3.1 prints 2.76."""
        return float(self.c[1])

    @property
    def mu(self):
        """Scaled damping μ = 2Γ/ε (3.17)."""
        return 2.0 * self.gamma / self.eps

    def natural_frequencies_hz(self):
        """Dimensional f_1, f_2 of the mean system (Hz)."""
        return self.omega_nat / (2 * math.pi)

    def mesh_frequency_hz(self, omega):
        """Dimensional mesh frequency (Hz) of the dimensionless mesh frequency ω = ω̃/ω_1."""
        return omega * self.omega_1 / (2 * math.pi)

    def pinion_speed(self, omega):
        """Pinion speed (rad/s) for the dimensionless mesh frequency ω: ω̃ = z_1 Ω_pinion."""
        return omega * self.omega_1 / self.teeth[0]

    def omega_of_speed(self, speed):
        """Dimensionless mesh frequency of a pinion speed (rad/s)."""
        return speed * self.teeth[0] / self.omega_1

    def kappa(self, m):
        """κ̃_m/k̄_1 (complex, mesh 1; 3.12-3.13 in the time-domain convention)."""
        return rectangular_harmonic(m, self.contact_ratio[0], self.pp_ratio[0])

    def eta(self, m):
        """η̃_m/k̄_1 = λ η̃_m/k̄_2 (complex, mesh 2, with its phase lead φ)."""
        return self.lam * rectangular_harmonic(m, self.contact_ratio[1], self.pp_ratio[1], self.phi)

    def stiffness(self, j, p):
        """k_j/k̄_1 at mesh-1 phase p (cycles), the time-domain wave the harmonics come from."""
        f = self.contact_ratio[j] - math.floor(self.contact_ratio[j])
        mean = 1.0 if j == 0 else self.lam
        s = (p + (0.0 if j == 0 else self.phi / (2 * math.pi))) % 1.0
        low = mean * (1.0 - f * self.pp_ratio[j])
        return low if s < 1.0 - f else low + self.pp_ratio[j] * mean

    # -- excitation coefficients (3.27), (3.32), (3.36), (3.38) ------------------------------------
    def R3(self, r=0):
        """R_3 = s_1r C_1 κ̃_1/k̄_1 + λ s_2r C_2 η̃_1/k̄_2 (3.32), complex."""
        s = self.S[:, r]
        return s[0] * self.C[0] * self.kappa(1) + s[1] * self.C[1] * self.eta(1)

    def R3_tilde(self, r=0):
        """R̃_3 of the second-harmonic resonance (3.38): the second stiffness harmonics."""
        s = self.S[:, r]
        return s[0] * self.C[0] * self.kappa(2) + s[1] * self.C[1] * self.eta(2)

    def R4(self, r=0):
        """εR̂_4 = s_1r² κ̃_2/k̄_1 + λ s_2r² η̃_2/k̄_2 (erratum: the print's (3.27) copies R̂_3)."""
        s = self.S[:, r]
        return s[0] ** 2 * self.kappa(2) + s[1] ** 2 * self.eta(2)

    def Q3(self, r=0):
        """Q_3 = s_1r² κ̃_1/k̄_1 + λ s_2r² η̃_1/k̄_2 (3.36), complex."""
        s = self.S[:, r]
        return s[0] ** 2 * self.kappa(1) + s[1] ** 2 * self.eta(1)

    # -- contact loss: separation angles and the θ-functions (3.16), (3.30), (3.32) ----------------
    def alpha_c(self, r=0):
        """Per-mesh onset amplitudes C_j/(2|s_jr|) (3.33); the first to separate is the min."""
        return self.C / (2.0 * np.abs(self.S[:, r]))

    def theta(self, alpha, r=0):
        """Separation half-angles θ_j (3.30), clean form arccos(C_j/(2|s_jr|α)), 0 below onset."""
        a = 2.0 * np.abs(self.S[:, r]) * alpha
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(a > self.C, self.C / np.where(a > 0, a, 1.0), 1.0)
        return np.arccos(np.clip(ratio, -1.0, 1.0))

    def R1(self, alpha, r=0):
        """R_1 = −Σ_j λ_j s_jr² (sinθ_j cosθ_j + θ_j)/π (3.32)."""
        th = self.theta(alpha, r)
        w = np.array([1.0, self.lam]) * self.S[:, r] ** 2
        return -float(np.sum(w * (np.sin(th) * np.cos(th) + th))) / math.pi

    def R2(self, alpha, r=0):
        """R_2 = Σ_j λ_j |s_jr| C_j sinθ_j/π (3.32, erratum: |s_jr|)."""
        th = self.theta(alpha, r)
        w = np.array([1.0, self.lam]) * np.abs(self.S[:, r]) * self.C
        return float(np.sum(w * np.sin(th))) / math.pi

    # -- fundamental resonance ω ≈ c_r (3.31)-(3.34) -----------------------------------------------
    def backbone(self, alpha, r=0):
        """Backbone ω = c_r + (R_1α + R_2)/(2αc_r) (text after 3.32)."""
        cr = self.c[r]
        return cr + (self.R1(alpha, r) * alpha + self.R2(alpha, r)) / (2.0 * alpha * cr)

    def branches(self, alpha, r=0):
        """(ω_−, ω_+) of (3.31) at the modal amplitude α (None above the peak α_p)."""
        cr = self.c[r]
        R3sq = abs(self.R3(r)) ** 2
        disc = R3sq - 4.0 * self.gamma ** 2 * alpha ** 2 * cr ** 4
        if disc < 0:
            if disc < -1e-12 * R3sq:
                return None
            disc = 0.0                                 # α = α_p up to rounding
        w = self.backbone(alpha, r)
        d = math.sqrt(disc) / (2.0 * alpha * cr)
        return w - d, w + d

    def peak(self, r=0):
        """(α_p, ω_p) of (3.34): α_p = |R_3|/(2Γc_r²), ω_p = c_r + R_1/(2c_r) + Γc_r R_2/|R_3|."""
        cr = self.c[r]
        ap = abs(self.R3(r)) / (2.0 * self.gamma * cr ** 2)
        wp = cr + self.R1(ap, r) / (2 * cr) + self.gamma * cr * self.R2(ap, r) / abs(self.R3(r))
        return ap, wp

    def onset_linear(self, r=0, j=None):
        """(3.33): transition frequencies ω_c1,c2 = c_r ± √(|R_3|² − 4Γ²α_c²c_r⁴)/(2α_c c_r) where
        the *linear* branch reaches the onset amplitude of mesh j (default: the first mesh to
        separate).  For that mesh this is the corrected (3.43).  None if the linear peak stays
        below the onset."""
        ac = self.alpha_c(r)
        a = float(ac.min() if j is None else ac[j])
        cr = self.c[r]
        disc = abs(self.R3(r)) ** 2 - 4.0 * self.gamma ** 2 * a ** 2 * cr ** 4
        if disc < 0:
            return None
        d = math.sqrt(disc) / (2.0 * a * cr)
        return cr - d, cr + d

    def onset(self, r=0, j=0):
        """Frequencies where mesh j starts/stops losing contact on the nonlinear curve (3.31) at
        α = C_j/(2|s_jr|): equals `onset_linear` for the first mesh to separate; for the second
        it includes the first mesh's separation (Fig. 3.4a: 'mesh 1 at 0.875 and 1.073')."""
        return self.branches(float(self.alpha_c(r)[j]), r)

    def _curve(self, r=0, n=4000):
        """Samples of the closed-form curve: α grid (0, α_p] and ω_−, ω_+."""
        ap, _ = self.peak(r)
        # Denser near α_p (square-root behaviour of the branches there).
        u = np.linspace(0.0, 1.0, n + 1)[1:]
        alphas = ap * (1.0 - (1.0 - u) ** 2)
        lo = np.empty(n)
        hi = np.empty(n)
        for i, a in enumerate(alphas):
            b = self.branches(a, r)
            lo[i], hi[i] = b if b is not None else (np.nan, np.nan)
        return alphas, lo, hi

    def response(self, omega, r=0, n=4000):
        """All steady amplitudes α at mesh frequency ω from (3.31), with stability (Jacobian of
        the slow flow 3.29).  Returns a list of (α, stable), ascending in α."""
        alphas, lo, hi = self._curve(r, n)
        # One path along the curve: ω_− for α ascending to α_p, then ω_+ descending (so a
        # solution at the top, ω ≈ ω_p, is not missed).
        a = np.concatenate([alphas, alphas[::-1]])
        g = np.concatenate([lo, hi[::-1]]) - omega
        upper = np.concatenate([np.zeros(n, bool), np.ones(n, bool)])
        roots = []
        for i in range(len(a) - 1):
            if not (np.isfinite(g[i]) and np.isfinite(g[i + 1])):
                continue
            if upper[i] != upper[i + 1] and abs(g[i]) < 1e-9:   # ω = ω_p at the top
                roots.append(float(a[i]))
            elif g[i] * g[i + 1] <= 0 and g[i] != g[i + 1]:
                if upper[i] == upper[i + 1]:
                    roots.append(self._bisect(min(a[i], a[i + 1]), max(a[i], a[i + 1]), omega, r, bool(upper[i])))
                else:                                  # across the top: the root is ≈ α_p
                    roots.append(float(a[i]))
        roots = sorted(set(round(x, 12) for x in roots))
        return [(x, self.stable(x, omega, r)) for x in roots]

    def _bisect(self, a0, a1, omega, r, upper):
        def g(a):
            b = self.branches(a, r)
            if b is None:
                b = (self.backbone(a, r),) * 2
            return (b[1] if upper else b[0]) - omega

        g0 = g(a0)
        for _ in range(200):
            am = 0.5 * (a0 + a1)
            gm = g(am)
            if (gm <= 0) == (g0 <= 0):
                a0, g0 = am, gm
            else:
                a1 = am
            if a1 - a0 < 1e-14 * max(1.0, a1):
                break
        return 0.5 * (a0 + a1)

    def slow_flow(self, alpha, gam, omega, r=0):
        """(3.29) in the physical slow time (ε-scaled): α', γ' with σε = ω − c_r.  γ is the
        phase lag of the response to exp(iωτ) relative to R_3's phase ψ (γ + ψ → γ)."""
        cr = self.c[r]
        R3 = abs(self.R3(r))
        da = -(2 * self.gamma * cr ** 2 * alpha + R3 * math.sin(gam)) / (2 * cr)
        dg = (omega - cr) - (self.R1(alpha, r) * alpha + self.R2(alpha, r) + R3 * math.cos(gam)) / (2 * cr * alpha)
        return da, dg

    def stable(self, alpha, omega, r=0):
        """Stability of the fixed point (α, γ) of (3.29) at ω (finite-difference Jacobian).
        The trace is −2Γc_r, so the fixed point is stable iff the determinant is positive."""
        cr = self.c[r]
        R3 = abs(self.R3(r))
        sin_g = -2 * self.gamma * cr ** 2 * alpha / R3
        cos_g = (2 * cr * alpha * (omega - cr) - self.R1(alpha, r) * alpha - self.R2(alpha, r)) / R3
        gam = math.atan2(sin_g, cos_g)
        h = 1e-7 * max(alpha, 1e-3)
        J = np.empty((2, 2))
        for k, (dx, dy) in enumerate(((h, 0.0), (0.0, 1e-7))):
            p = self.slow_flow(alpha + dx, gam + dy, omega, r)
            m = self.slow_flow(alpha - dx, gam - dy, omega, r)
            J[:, k] = (np.array(p) - np.array(m)) / (2 * (dx + dy))
        return bool(np.all(np.linalg.eigvals(J).real < 0))

    def folds(self, r=0, n=8000):
        """Jump frequencies of the (softening) curve (3.31): the local maximum of ω_−(α) (where
        the lower branch ends: jump up in an up-sweep) and the minimum of the whole curve (where
        the upper branch ends: jump down in a down-sweep).  dict(up=(ω, α) or None, down=(ω, α))."""
        alphas, lo, hi = self._curve(r, n)
        # One path along the closed-form curve: ω_− for α ascending to α_p, then ω_+ descending.
        a = np.concatenate([alphas, alphas[::-1]])
        w = np.concatenate([lo, hi[::-1]])
        ok = np.isfinite(w)
        a, w = a[ok], w[ok]
        # First local maximum of ω along the path (the lower branch turns back: jump up).
        up = None
        i_up = 0
        for i in range(1, len(w) - 1):
            if w[i] > w[i - 1] and w[i] >= w[i + 1]:
                up = (float(w[i]), float(a[i]))
                i_up = i
                break
        if up is None:
            return dict(up=None, down=None)
        # Leftmost point of the curve beyond it (the upper branch turns back: jump down).
        i_dn = i_up + int(np.argmin(w[i_up:]))
        return dict(up=up, down=(float(w[i_dn]), float(a[i_dn])))

    def dte_amplitude(self, alpha, r=0):
        """First-harmonic DTE amplitudes 2|s_jr|α of the two meshes (3.25), dimensionless."""
        return 2.0 * np.abs(self.S[:, r]) * alpha

    def dte_rms(self, alpha, r=0):
        """Mean-removed RMS √2|s_jr|α (notes §6), dimensionless (× x̄_1 for metres)."""
        return math.sqrt(2.0) * np.abs(self.S[:, r]) * alpha

    def contact_loss_fraction(self, alpha, r=0):
        """Fraction of the response period with mesh j separated: θ_j/π (notes §6)."""
        return self.theta(alpha, r) / math.pi

    def response_two_harmonics(self, omega, r=0, alpha0=None):
        """Steady amplitude from the compact complex form of (3.28) (notes §2.5 [R]) that keeps
        the second stiffness harmonics: [2c_r(ω−c_r) − R_1 − R_2/α − 2iΓc_r²] B − R_4 B̄ = R_3,
        α = |B|; fixed-point iteration from alpha0 (default: the one-harmonic result)."""
        cr = self.c[r]
        if alpha0 is None:
            sols = self.response(omega, r)
            alpha0 = sols[-1][0] if sols else 0.1
        B = complex(alpha0)
        R3, R4 = self.R3(r), self.R4(r)
        for _ in range(500):
            a = abs(B)
            d = 2 * cr * (omega - cr) - self.R1(a, r) - self.R2(a, r) / a - 2j * self.gamma * cr ** 2
            # Solve d B − R4 B̄ = R3 for B (2x2 real linear system).
            A = np.array([[d.real - R4.real, -d.imag - R4.imag],
                          [d.imag - R4.imag, d.real + R4.real]])
            x = np.linalg.solve(A, [R3.real, R3.imag])
            Bn = complex(x[0], x[1])
            if abs(Bn - B) < 1e-13:
                B = Bn
                break
            B = 0.5 * B + 0.5 * Bn
        return abs(B)

    # -- subharmonic ω ≈ 2c_r (3.35), (3.36), (3.44) -------------------------------------------------
    def subharmonic_exists(self, r=0):
        """Period-2T_m resonance exists iff |Q_3| ≥ 2Γc_r² (text after 3.44; = 2Γ for r = 1)."""
        return abs(self.Q3(r)) >= 2.0 * self.gamma * self.c[r] ** 2

    def subharmonic_interval(self, r=0):
        """(ω_c1, ω_c2) = 2c_r ∓ √(|Q_3|² − 4Γ²c_r⁴)/c_r (3.35 with Q_1 = Q_2 = 0; erratum: the
        print has c_r ±), the primary instability interval of the period-T_m solution; None if
        it does not exist.  Its width is ω_int of (3.44)."""
        cr = self.c[r]
        disc = abs(self.Q3(r)) ** 2 - 4.0 * self.gamma ** 2 * cr ** 4
        if disc < 0:
            return None
        d = math.sqrt(disc) / cr
        return 2 * cr - d, 2 * cr + d

    def subharmonic_width_sensitivity(self, r=0):
        """dω_int/dΓ = −8c_r³Γ/√(|Q_3|² − 4Γ²c_r⁴) (3.44)."""
        cr = self.c[r]
        return -8 * cr ** 3 * self.gamma / math.sqrt(abs(self.Q3(r)) ** 2 - 4 * self.gamma ** 2 * cr ** 4)

    def subharmonic_branches(self, alpha, r=0):
        """(3.35): ω = 2c_r + (Q_1α + Q_2)/(c_rα) ± √(|Q_3|² − 4Γ²c_r⁴)/c_r, α the amplitude of
        the period-2T_m mode response (y_j = C_j + 2s_jrα cos(ωτ/2 − γ)); Q_1 = R_1, Q_2 = R_2."""
        iv = self.subharmonic_interval(r)
        if iv is None:
            return None
        cr = self.c[r]
        shift = (self.R1(alpha, r) * alpha + self.R2(alpha, r)) / (cr * alpha)
        return iv[0] + shift, iv[1] + shift

    # -- ω ≈ c_r/2: second-harmonic (3.37)-(3.38) and super-harmonic (3.39)-(3.42) ---------------
    def second_harmonic_branches(self, alpha, r=0):
        """(3.37): ω = c_r/2 + (R_1α + R_2 ± √(|R̃_3|² − 4Γ²α²c_r⁴))/(4αc_r); response at 2ω."""
        cr = self.c[r]
        disc = abs(self.R3_tilde(r)) ** 2 - 4 * self.gamma ** 2 * alpha ** 2 * cr ** 4
        if disc < 0:
            return None
        w = cr / 2 + (self.R1(alpha, r) * alpha + self.R2(alpha, r)) / (4 * alpha * cr)
        d = math.sqrt(disc) / (4 * alpha * cr)
        return w - d, w + d

    def superharmonic_W(self, r=0):
        """W of (3.42) with B_l of (3.39) at ω = c_r/2, built from κ̃_1/k̄_1 (actual first-order
        amplitudes), so that W is the O(ε²) forcing of mode r at 2ω."""
        w = self.c[r] / 2
        B = np.array([(self.S[0, l] * self.C[0] * self.kappa(1) + self.S[1, l] * self.C[1] * self.eta(1))
                      / (w ** 2 - self.c[l] ** 2) for l in range(2)])
        s = self.S[:, r]
        return s[0] * (self.S[0] @ B) * self.kappa(1) + s[1] * (self.S[1] @ B) * self.eta(1)

    def superharmonic_branches(self, alpha, r=0):
        """(3.41) with the 1/(4αc_r) prefactor (erratum [?] of the notes): ω = c_r/2 +
        (R_1α ± √(|W|² − 4Γ²α²c_r⁴))/(4αc_r).  Not validated numerically here."""
        cr = self.c[r]
        disc = abs(self.superharmonic_W(r)) ** 2 - 4 * self.gamma ** 2 * alpha ** 2 * cr ** 4
        if disc < 0:
            return None
        w = cr / 2 + self.R1(alpha, r) / (4 * cr)
        d = math.sqrt(disc) / (4 * alpha * cr)
        return w - d, w + d

    # -- mesh-interaction indicators (3.45)-(3.50) ------------------------------------------------
    def relative_phase(self):
        """Phase of η̃_1 relative to κ̃_1: φ + π(ς_2 − ς_1) (time-domain convention; the print's
        (3.45) has φ + π(ς_1 − ς_2), the same for ς_1 = ς_2)."""
        return float(np.angle(self.eta(1) / self.kappa(1)))

    def indicator_R3(self, r=0):
        """(3.45): |R_3| = |s_1r C_1 κ̂_1 + s_2r C_2 η̂_1 e^{iΔ}|/k̄_1 (= |R3(r)|)."""
        s = self.S[:, r]
        d = self.relative_phase()
        return abs(s[0] * self.C[0] * abs(self.kappa(1)) + s[1] * self.C[1] * abs(self.eta(1)) * np.exp(1j * d))

    def indicator_R3_equal(self, r=0):
        """(3.46)/(3.48): |R_3| = κ̂_1 {s_1r²C_1² + 2C_1C_2 s_1r s_2r cos Δ + s_2r²C_2²}^{1/2}/k̄_1,
        valid when the two harmonic magnitudes are equal (κ̂_1 = η̂_1, i.e. Λ_1 = Λ_2 here only
        if pp_ratio_2 = pp_ratio_1/λ).  Δ = φ (3.46) or φ ± π(ς_1 − ς_2) (3.48)."""
        s = self.S[:, r]
        k = abs(self.kappa(1))
        d = self.relative_phase()
        return k * math.sqrt(s[0] ** 2 * self.C[0] ** 2 + 2 * self.C[0] * self.C[1] * s[0] * s[1] * math.cos(d)
                             + s[1] ** 2 * self.C[1] ** 2)

    def indicator_Q3_equal(self, r=0):
        """(3.47): |Q_3| = κ̂_1 (s_1r⁴ + 2s_1r²s_2r² cos φ + s_2r⁴)^{1/2}/k̄_1 (equal magnitudes)."""
        s = self.S[:, r]
        return abs(self.kappa(1)) * math.sqrt(s[0] ** 4 + 2 * s[0] ** 2 * s[1] ** 2 * math.cos(self.relative_phase())
                                              + s[1] ** 4)

    def indicator_R3_tilde_equal(self, r=0):
        """(3.47): |R̃_3| = κ̂_2 (s_1r²C_1² + 2C_1C_2 s_1r s_2r cos 2φ + s_2r²C_2²)^{1/2}/k̄_1."""
        s = self.S[:, r]
        d2 = float(np.angle(self.eta(2) / self.kappa(2))) if abs(self.kappa(2)) > 1e-15 else 2 * self.phi
        return abs(self.kappa(2)) * math.sqrt(s[0] ** 2 * self.C[0] ** 2
                                              + 2 * self.C[0] * self.C[1] * s[0] * s[1] * math.cos(d2)
                                              + s[1] ** 2 * self.C[1] ** 2)

    def indicator_R3_rect(self, r=0):
        """(3.49) (φ = 0) / (3.50) (φ = π) for rectangular waves with ς_1 = 1.5:
        |R̂_3| = [s_1r²C_1² ± (Λ_2/Λ_1)s_2rC_2(2s_1rC_1 ± (Λ_2/Λ_1)s_2rC_2) sin²(πς_2)]^{1/2}/2,
        the printed '/2' being (Λ_1/π)/k̄_1 = ε/2 per unit ε (notes §2.7 [R]); returned × ε,
        i.e. comparable with |R3|.  Only for φ ∈ {0, π} and ς_1 = 1.5."""
        s = self.S[:, r]
        ratio = self.lam * self.pp_ratio[1] / self.pp_ratio[0]      # Λ_2/Λ_1
        sign = 1.0 if abs(math.cos(self.phi) - 1) < 1e-12 else -1.0
        a = s[1] * self.C[1] * ratio
        val = s[0] ** 2 * self.C[0] ** 2 + sign * a * (2 * s[0] * self.C[0] + sign * a) * math.sin(
            math.pi * self.contact_ratio[1]) ** 2
        return math.sqrt(val) / 2 * self.eps

    # -- equations of motion for a numerical check ---------------------------------------------------
    def rhs_matrices(self):
        """(M̂, Ĉ, F̂): M̂ÿ + Ĉẏ + diag(H_j k_j/k̄_1) y = F̂ = [1, 1] (3.10) with modal damping."""
        return self.Mhat.copy(), self.Chat.copy(), np.ones(2)

    def summary(self, r=0):
        """Dict of the main closed-form numbers (for printing/docs)."""
        ap, wp = self.peak(r)
        fl = self.folds(r)
        return dict(
            eps=self.eps, gamma=self.gamma, mu=self.mu, phi=self.phi, c=self.c_ratio,
            f_nat_hz=tuple(self.natural_frequencies_hz()), S=self.S.tolist(), F=self.F.tolist(),
            C=self.C.tolist(), R3=abs(self.R3(r)), Q3=abs(self.Q3(r)), alpha_c=self.alpha_c(r).tolist(),
            alpha_p=ap, omega_p=wp, onset_linear=self.onset_linear(r),
            onset_mesh1=self.onset(r, 0), onset_mesh2=self.onset(r, 1),
            fold_up=fl["up"], fold_down=fl["down"],
            subharmonic_exists=self.subharmonic_exists(r), subharmonic_interval=self.subharmonic_interval(r),
        )


def _mass_normalised_modes(K, M):
    """Generalised symmetric eigenproblem K s = c² M s, Sᵀ M S = I, ascending, S[0, l] > 0."""
    L = np.linalg.cholesky(M)
    Li = np.linalg.inv(L)
    w, V = np.linalg.eigh(Li @ K @ Li.T)
    S = Li.T @ V
    S = S * np.sign(S[0])
    return w, S


if __name__ == "__main__":
    import pprint

    for e in (0.2, 0.1, 0.05):
        pprint.pprint(IdlerCh3(eps=e, gamma=0.2 * e).summary(), sort_dicts=False)
