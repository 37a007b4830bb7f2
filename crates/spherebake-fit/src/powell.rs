//! Powell's direction-set method with Brent line minimisation (after Press et al., Numerical
//! Recipes §10.2/§10.7), for the 3-D sphere-centre update. Deterministic, derivative-free.

/// Result of a minimisation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PowellResult {
    pub x: [f64; 3],
    pub f: f64,
    /// Function evaluations used.
    pub evaluations: usize,
}

/// Minimises `f` from `x0`. `step` is the initial bracket step (model units), `sweeps` the
/// maximum number of direction-set sweeps, `ftol` the relative stop tolerance on f.
pub fn powell(f: &mut dyn FnMut([f64; 3]) -> f64, x0: [f64; 3], step: f64, sweeps: usize, ftol: f64) -> PowellResult {
    let mut evals = 0usize;
    let mut eval = |x: [f64; 3], evals: &mut usize| {
        *evals += 1;
        f(x)
    };
    let mut dirs = [[step, 0.0, 0.0], [0.0, step, 0.0], [0.0, 0.0, step]];
    let mut x = x0;
    let mut fx = eval(x, &mut evals);
    for _ in 0..sweeps {
        let x_start = x;
        let f_start = fx;
        let mut biggest = 0usize;
        let mut biggest_drop = 0.0;
        for (i, d) in dirs.iter().enumerate() {
            let before = fx;
            let (t, ft) = line_min(&mut |x| eval(x, &mut evals), x, fx, *d);
            x = add(x, *d, t);
            fx = ft;
            if before - fx > biggest_drop {
                biggest_drop = before - fx;
                biggest = i;
            }
        }
        if 2.0 * (f_start - fx) <= ftol * (f_start.abs() + fx.abs()) + 1e-300 {
            break;
        }
        // New direction: net displacement of the sweep.
        let nd = [x[0] - x_start[0], x[1] - x_start[1], x[2] - x_start[2]];
        let len2 = nd[0] * nd[0] + nd[1] * nd[1] + nd[2] * nd[2];
        if len2 > 0.0 {
            let ext = [2.0 * x[0] - x_start[0], 2.0 * x[1] - x_start[1], 2.0 * x[2] - x_start[2]];
            let fe = eval(ext, &mut evals);
            if fe < f_start {
                let (t, ft) = line_min(&mut |x| eval(x, &mut evals), x, fx, nd);
                x = add(x, nd, t);
                fx = ft;
                dirs[biggest] = dirs[2];
                dirs[2] = nd;
            }
        }
    }
    PowellResult { x, f: fx, evaluations: evals }
}

fn add(x: [f64; 3], d: [f64; 3], t: f64) -> [f64; 3] {
    [x[0] + t * d[0], x[1] + t * d[1], x[2] + t * d[2]]
}

/// Minimises t ↦ f(x + t d), returning (t, f). Brackets with golden expansion then runs
/// Brent's parabolic/golden search (≤ 20 iterations). Never returns a worse point than t = 0.
fn line_min(f: &mut dyn FnMut([f64; 3]) -> f64, x: [f64; 3], fx: f64, d: [f64; 3]) -> (f64, f64) {
    const GOLD: f64 = 1.618_033_988_749_895;
    let mut g = |t: f64| f(add(x, d, t));
    let (mut a, mut fa) = (0.0, fx);
    let (mut b, mut fb) = (1.0, g(1.0));
    if fb > fa {
        std::mem::swap(&mut a, &mut b);
        std::mem::swap(&mut fa, &mut fb);
    }
    let mut c = b + GOLD * (b - a);
    let mut fc = g(c);
    let mut guard = 0;
    while fb > fc && guard < 30 {
        a = b;
        fa = fb;
        b = c;
        fb = fc;
        c = b + GOLD * (b - a);
        fc = g(c);
        guard += 1;
    }
    let _ = fa;
    // Brent on [min(a,c), max(a,c)] with best point b.
    let (mut lo, mut hi) = if a < c { (a, c) } else { (c, a) };
    let (mut xb, mut fxb) = (b, fb);
    let (mut w, mut fw) = (b, fb);
    let (mut v, mut fv) = (b, fb);
    let mut e: f64 = 0.0;
    let mut dd: f64 = 0.0;
    const CGOLD: f64 = 0.381_966_011_250_105_1;
    for _ in 0..20 {
        let xm = 0.5 * (lo + hi);
        let tol1 = 1e-4 * xb.abs() + 1e-3;
        let tol2 = 2.0 * tol1;
        if (xb - xm).abs() <= tol2 - 0.5 * (hi - lo) {
            break;
        }
        let mut use_golden = true;
        if e.abs() > tol1 {
            let r = (xb - w) * (fxb - fv);
            let mut q = (xb - v) * (fxb - fw);
            let mut p = (xb - v) * q - (xb - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let etemp = e;
            e = dd;
            if !(p.abs() >= (0.5 * q * etemp).abs() || p <= q * (lo - xb) || p >= q * (hi - xb)) {
                dd = p / q;
                let u = xb + dd;
                if u - lo < tol2 || hi - u < tol2 {
                    dd = tol1.copysign(xm - xb);
                }
                use_golden = false;
            }
        }
        if use_golden {
            e = if xb >= xm { lo - xb } else { hi - xb };
            dd = CGOLD * e;
        }
        let u = if dd.abs() >= tol1 { xb + dd } else { xb + tol1.copysign(dd) };
        let fu = g(u);
        if fu <= fxb {
            if u >= xb {
                lo = xb;
            } else {
                hi = xb;
            }
            v = w;
            fv = fw;
            w = xb;
            fw = fxb;
            xb = u;
            fxb = fu;
        } else {
            if u < xb {
                lo = u;
            } else {
                hi = u;
            }
            if fu <= fw || w == xb {
                v = w;
                fv = fw;
                w = u;
                fw = fu;
            } else if fu <= fv || v == xb || v == w {
                v = u;
                fv = fu;
            }
        }
    }
    if fxb <= fx {
        (xb, fxb)
    } else {
        (0.0, fx)
    }
}
