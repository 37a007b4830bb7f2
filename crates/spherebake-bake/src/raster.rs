//! Software cube-map rasteriser for the albedo stage.
//!
//! A triangle is drawn into the cube map centred at the origin by testing each candidate texel's
//! centre direction against the triangle's cone (the three planes through the origin and an
//! edge). This is the ray–triangle test of a direction through the texel centre, so it samples
//! exactly the texel-centre directions the SH projection integrates (math reference §4), needs
//! no near plane and no clipping of the coverage test, and is watertight: two triangles sharing
//! an edge compute the edge plane normals `a × b` and `b × a`, which are exact negations in IEEE
//! arithmetic, so a direction on the shared edge is covered by at least one of them.
//!
//! Candidate texels come from the bounding box of the triangle clipped to each face's pyramid
//! (Sutherland–Hodgman on the four face planes through the origin); the box only limits which
//! texels are tested and is widened by a tiny margin, so it never decides coverage.
//!
//! Conventions: faces in OpenGL/Vulkan layer order (`spherebake_sh::CubeFace`), texel index
//! `(face·n + j)·n + i` (column i along s, row j along t), directions in model space.

use glam::DVec3;
use spherebake_sh::{cube_texel_direction, CubeFace};

/// The texel geometry of one cube-map size.
#[derive(Clone, Debug)]
pub(crate) struct CubeGrid {
    n: usize,
    /// Unit texel-centre directions, `6·n²`, face-major.
    dirs: Vec<DVec3>,
    /// Per texel of one face (`n²`, row-major): the solid angle of the texel's Jacobian at its
    /// centre, (2/n)² / (1+u²+v²)^{3/2} steradians (used for texture footprints, not for the
    /// projection, which uses exact solid angles).
    nominal_solid_angle: Vec<f64>,
    /// Face frames `[major, s_axis, t_axis]`.
    frames: [[DVec3; 3]; 6],
}

/// One covered texel: texel index, barycentric weights of the triangle's vertices (sum 1) at the
/// point seen, and that point's distance from the origin.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fragment {
    pub texel: usize,
    pub bary: [f64; 3],
    pub dist: f64,
}

impl CubeGrid {
    /// Texel geometry for `n`×`n` faces (`n ≥ 1`).
    pub fn new(n: usize) -> Self {
        let mut dirs = Vec::with_capacity(6 * n * n);
        for face in CubeFace::ALL {
            for j in 0..n {
                for i in 0..n {
                    dirs.push(DVec3::from_array(cube_texel_direction(face, i, j, n)));
                }
            }
        }
        let nf = n as f64;
        let mut nominal_solid_angle = Vec::with_capacity(n * n);
        for j in 0..n {
            for i in 0..n {
                let u = (2 * i + 1) as f64 / nf - 1.0;
                let v = (2 * j + 1) as f64 / nf - 1.0;
                let q = 1.0 + u * u + v * v;
                nominal_solid_angle.push((2.0 / nf) * (2.0 / nf) / (q * q.sqrt()));
            }
        }
        let frames = CubeFace::ALL.map(|f| f.frame().map(DVec3::from_array));
        Self { n, dirs, nominal_solid_angle, frames }
    }

    /// Texels per face edge.
    pub fn face_size(&self) -> usize {
        self.n
    }

    /// Number of texels `6·n²`.
    pub fn texel_count(&self) -> usize {
        self.dirs.len()
    }

    /// Unit centre direction of texel `t`.
    pub fn direction(&self, t: usize) -> DVec3 {
        self.dirs[t]
    }

    /// Nominal (centre-Jacobian) solid angle of texel `t`, steradians.
    pub fn nominal_solid_angle(&self, t: usize) -> f64 {
        self.nominal_solid_angle[t % (self.n * self.n)]
    }

    /// The face whose major axis has the largest coordinate of `p` (the first on ties), so
    /// that p lies in its closed pyramid; `None` for the origin or a non-finite `p`.
    fn face_of(&self, p: DVec3) -> Option<usize> {
        let mut best = (0usize, f64::NEG_INFINITY);
        for (face, frame) in self.frames.iter().enumerate() {
            let m = p.dot(frame[0]);
            if m > best.1 {
                best = (face, m);
            }
        }
        (best.1 > 0.0 && best.1.is_finite()).then_some(best.0)
    }

    /// Calls `f` for every texel whose centre direction lies in the cone of the triangle
    /// (`a`, `b`, `c` relative to the cube-map centre), in increasing texel order per face.
    /// Triangles whose plane contains the origin (seen edge-on) or with non-finite corners
    /// cover nothing.
    pub fn rasterize(&self, a: DVec3, b: DVec3, c: DVec3, mut f: impl FnMut(Fragment)) {
        let e0 = b.cross(c);
        let e1 = c.cross(a);
        let e2 = a.cross(b);
        let det = a.dot(e0);
        if det == 0.0 || !det.is_finite() {
            return;
        }
        let sign = det.signum();
        let abs_det = det.abs();
        let n = self.n;
        let nf = n as f64;
        // Corners in one face's closed pyramid: so is the triangle (convex), and no other
        // face's texel centre (strictly inside its own pyramid) can lie in its cone.
        let only = self.face_of(a).filter(|&f| self.face_of(b) == Some(f) && self.face_of(c) == Some(f));
        for (face, frame) in self.frames.iter().enumerate() {
            if only.is_some_and(|f| f != face) {
                continue;
            }
            let Some((i0, i1, j0, j1)) = face_texel_range(frame, [a, b, c], nf) else { continue };
            for j in j0..=j1 {
                let row = (face * n + j) * n;
                for i in i0..=i1 {
                    let texel = row + i;
                    let d = self.dirs[texel];
                    let w0 = sign * d.dot(e0);
                    let w1 = sign * d.dot(e1);
                    let w2 = sign * d.dot(e2);
                    if w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0 {
                        let sum = w0 + w1 + w2;
                        if sum > 0.0 {
                            f(Fragment { texel, bary: [w0 / sum, w1 / sum, w2 / sum], dist: abs_det / sum });
                        }
                    }
                }
            }
        }
    }
}

impl CubeGrid {
    /// Whether every texel whose centre direction could meet the box [`lo`, `hi`] (relative
    /// to the cube-map centre) is set in `covered` (one flag per texel), so that no triangle
    /// inside the box can cover an unset texel. Conservative: a box that holds the centre or
    /// is not finite is never covered; a face the box meets only partly (some corner outside
    /// its pyramid) is checked whole; otherwise the texels of the corners' projected bounding
    /// rectangle, which holds the projection of the whole box (u = sc/ma is quasi-linear where
    /// ma > 0), with the rasteriser's own margin.
    pub fn box_covered(&self, lo: DVec3, hi: DVec3, covered: &[bool]) -> bool {
        if !(lo.is_finite() && hi.is_finite()) || (lo.cmple(DVec3::ZERO).all() && hi.cmpge(DVec3::ZERO).all()) {
            return false;
        }
        let corners: [DVec3; 8] = std::array::from_fn(|k| {
            DVec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            )
        });
        let (n, nf) = (self.n, self.n as f64);
        for (face, frame) in self.frames.iter().enumerate() {
            let q = corners.map(|p| [p.dot(frame[0]), p.dot(frame[1]), p.dot(frame[2])]);
            // Every corner outside one plane of the face's pyramid: so is the whole box.
            let Some(inside) = pyramid_side(&q) else { continue };
            let (i0, i1, j0, j1) = if inside {
                match projected_texels(&q, nf) {
                    Some(r) => r,
                    None => continue,
                }
            } else {
                (0, n - 1, 0, n - 1)
            };
            for j in j0..=j1 {
                let row = (face * n + j) * n;
                if !covered[row + i0..=row + i1].iter().all(|&c| c) {
                    return false;
                }
            }
        }
        true
    }
}

/// Inclusive texel ranges `(i0, i1, j0, j1)` of one face whose centres may lie in the
/// triangle's cone, or `None` when the triangle misses the face.
fn face_texel_range(frame: &[DVec3; 3], tri: [DVec3; 3], nf: f64) -> Option<(usize, usize, usize, usize)> {
    // Face coordinates (ma, sc, tc) of each corner.
    let q = tri.map(|p| [p.dot(frame[0]), p.dot(frame[1]), p.dot(frame[2])]);
    if pyramid_side(&q)? {
        return projected_texels(&q, nf);
    }
    let (mut umin, mut umax, mut vmin, mut vmax) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    let mut add = |v: &[f64; 3]| -> bool {
        if v[0] <= 0.0 {
            return false;
        }
        let (u, w) = (v[1] / v[0], v[2] / v[0]);
        if !(u.is_finite() && w.is_finite()) {
            return false;
        }
        umin = umin.min(u);
        umax = umax.max(u);
        vmin = vmin.min(w);
        vmax = vmax.max(w);
        true
    };
    let poly = clip_to_pyramid(&q);
    if poly.is_empty() {
        return None;
    }
    let mut full = false;
    for v in &poly {
        // A clipped corner at (or numerically near) the apex has no stable projection:
        // fall back to the whole face (the cone test still decides coverage).
        if !add(v) || v[0] <= 1e-12 * (v[1].abs() + v[2].abs() + v[0].abs()).max(f64::MIN_POSITIVE) {
            full = true;
        }
    }
    if full {
        (umin, umax, vmin, vmax) = (-1.0, 1.0, -1.0, 1.0);
    }
    let (i0, i1) = texel_range(umin, umax, nf)?;
    let (j0, j1) = texel_range(vmin, vmax, nf)?;
    Some((i0, i1, j0, j1))
}

/// Where points in face coordinates (ma, sc, tc) lie against the face's pyramid |sc| ≤ ma,
/// |tc| ≤ ma: `None` when all are outside one of its four planes (then so is their convex
/// hull), `Some(true)` when all are inside with ma > 0, `Some(false)` otherwise.
fn pyramid_side(q: &[[f64; 3]]) -> Option<bool> {
    let outside = |k: usize, sgn: f64| q.iter().all(|v| sgn * v[k] > v[0]);
    if outside(1, 1.0) || outside(1, -1.0) || outside(2, 1.0) || outside(2, -1.0) {
        return None;
    }
    Some(q.iter().all(|v| v[0] > 0.0 && v[1].abs() <= v[0] && v[2].abs() <= v[0]))
}

/// Inclusive texel ranges `(i0, i1, j0, j1)` of the bounding rectangle of the projections
/// (u, v) = (sc, tc)/ma of points inside the face's pyramid ([`pyramid_side`] `Some(true)`),
/// which holds the projection of their convex hull (u is quasi-linear where ma > 0); `None`
/// when no texel centre lies in it.
fn projected_texels(q: &[[f64; 3]], nf: f64) -> Option<(usize, usize, usize, usize)> {
    let (mut umin, mut umax, mut vmin, mut vmax) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for v in q {
        let (u, w) = (v[1] / v[0], v[2] / v[0]);
        umin = umin.min(u);
        umax = umax.max(u);
        vmin = vmin.min(w);
        vmax = vmax.max(w);
    }
    let (i0, i1) = texel_range(umin, umax, nf)?;
    let (j0, j1) = texel_range(vmin, vmax, nf)?;
    Some((i0, i1, j0, j1))
}

/// The texel columns (or rows) whose centres may lie in the face coordinate interval
/// [lo, hi] (u = sc/ma), widened by a tiny margin; `None` when there are none.
fn texel_range(lo: f64, hi: f64, nf: f64) -> Option<(usize, usize)> {
    // Texel centre k is at s = (k + ½)/n, s = (u + 1)/2: k = (u + 1)/2·n − ½.
    let lo = ((lo.max(-1.0) + 1.0) * 0.5 * nf - 0.5 - 1e-6).ceil().max(0.0);
    let hi = ((hi.min(1.0) + 1.0) * 0.5 * nf - 0.5 + 1e-6).floor().min(nf - 1.0);
    if lo > hi || !lo.is_finite() || !hi.is_finite() {
        return None;
    }
    Some((lo as usize, hi as usize))
}

/// Clips a triangle given in face coordinates (ma, sc, tc) to the pyramid |sc| ≤ ma, |tc| ≤ ma.
fn clip_to_pyramid(tri: &[[f64; 3]; 3]) -> Vec<[f64; 3]> {
    let mut poly: Vec<[f64; 3]> = tri.to_vec();
    // Plane k: value g(v) = ma − sgn·v[axis] ≥ 0 inside.
    for (axis, sgn) in [(1usize, 1.0f64), (1, -1.0), (2, 1.0), (2, -1.0)] {
        if poly.is_empty() {
            break;
        }
        let g = |v: &[f64; 3]| v[0] - sgn * v[axis];
        let mut out = Vec::with_capacity(poly.len() + 1);
        for k in 0..poly.len() {
            let p = poly[k];
            let q = poly[(k + 1) % poly.len()];
            let (gp, gq) = (g(&p), g(&q));
            if gp >= 0.0 {
                out.push(p);
            }
            if (gp >= 0.0) != (gq >= 0.0) {
                let t = gp / (gp - gq);
                out.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1]), p[2] + t * (q[2] - p[2])]);
            }
        }
        poly = out;
    }
    poly
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic xorshift64 numbers in [−1, 1).
    fn uniform(seed: u64) -> impl FnMut() -> f64 {
        let mut x = seed;
        move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }

    /// Brute force: every texel direction tested against the cone, no bounding boxes.
    fn brute(grid: &CubeGrid, a: DVec3, b: DVec3, c: DVec3) -> Vec<usize> {
        let det = a.dot(b.cross(c));
        let s = det.signum();
        (0..grid.texel_count())
            .filter(|&t| {
                let d = grid.direction(t);
                s * d.dot(b.cross(c)) >= 0.0 && s * d.dot(c.cross(a)) >= 0.0 && s * d.dot(a.cross(b)) >= 0.0
            })
            .collect()
    }

    #[test]
    fn bounding_boxes_never_lose_texels() {
        let grid = CubeGrid::new(16);
        // Deterministic pseudo-random triangles of all sizes and positions around the origin,
        // including ones spanning several faces and ones surrounding the origin closely.
        let mut rnd = uniform(0x1234_5678_9abc_def0);
        for k in 0..400 {
            let scale = [0.01, 0.3, 1.0, 5.0][k % 4];
            let centre = DVec3::new(rnd(), rnd(), rnd()) * 1.5;
            let a = centre + DVec3::new(rnd(), rnd(), rnd()) * scale;
            let b = centre + DVec3::new(rnd(), rnd(), rnd()) * scale;
            let c = centre + DVec3::new(rnd(), rnd(), rnd()) * scale;
            let mut got = Vec::new();
            grid.rasterize(a, b, c, |f| got.push(f.texel));
            got.sort_unstable();
            assert_eq!(got, brute(&grid, a, b, c), "triangle {k}: {a} {b} {c}");
        }
    }

    /// Brute force: the texels whose centre ray from the origin meets the box (slab test).
    fn reachable(grid: &CubeGrid, lo: DVec3, hi: DVec3) -> Vec<usize> {
        (0..grid.texel_count())
            .filter(|&t| {
                let d = grid.direction(t);
                let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
                for k in 0..3 {
                    if d[k] == 0.0 {
                        if lo[k] > 0.0 || hi[k] < 0.0 {
                            return false;
                        }
                        continue;
                    }
                    let (a, b) = (lo[k] / d[k], hi[k] / d[k]);
                    t0 = t0.max(a.min(b));
                    t1 = t1.min(a.max(b));
                }
                t0 <= t1
            })
            .collect()
    }

    #[test]
    fn a_covered_box_has_every_texel_it_can_reach_covered() {
        let grid = CubeGrid::new(8);
        let mut rnd = uniform(0x0bad_cafe_1234_5678);
        let (mut skipped, mut caught) = (0, 0);
        for k in 0..600 {
            // Small boxes inside one face, boxes across faces, boxes around the origin.
            let size = [0.02, 0.2, 1.0][k % 3];
            let c = DVec3::new(rnd(), rnd(), rnd()) * 1.2;
            let e = DVec3::new(rnd().abs(), rnd().abs(), rnd().abs()) * size;
            let (lo, hi) = (c - e, c + e);
            let reach = reachable(&grid, lo, hi);
            // Everything covered: the box is covered unless it holds the origin.
            let all = vec![true; grid.texel_count()];
            let holds_origin = lo.cmple(DVec3::ZERO).all() && hi.cmpge(DVec3::ZERO).all();
            assert_eq!(grid.box_covered(lo, hi, &all), !holds_origin, "box {k}");
            // One texel the box reaches left unset: never covered.
            if let Some(&t) = reach.get(k % reach.len().max(1)) {
                let mut one = all.clone();
                one[t] = false;
                assert!(!grid.box_covered(lo, hi, &one), "box {k}, texel {t}");
                caught += 1;
            }
            // Random masks: covered implies every reachable texel set.
            let mask: Vec<bool> = (0..grid.texel_count()).map(|_| rnd() > -0.9).collect();
            if grid.box_covered(lo, hi, &mask) {
                skipped += 1;
                assert!(reach.iter().all(|&t| mask[t]), "box {k}");
            }
        }
        assert!(caught > 300 && skipped > 20, "caught {caught}, skipped {skipped}");
        // Non-finite boxes are never covered.
        let all = vec![true; grid.texel_count()];
        assert!(!grid.box_covered(DVec3::NAN, DVec3::ONE, &all));
    }

    #[test]
    fn closed_octahedron_covers_every_texel_once_up_to_shared_edges() {
        // The octahedron's faces partition the sphere of directions; with the origin inside, every
        // texel is covered, and the distance is that of the face plane |x|+|y|+|z| = 1 along d.
        for n in [1, 2, 7, 32] {
            let grid = CubeGrid::new(n);
            let mut count = vec![0u32; grid.texel_count()];
            for sx in [-1.0, 1.0] {
                for sy in [-1.0, 1.0] {
                    for sz in [-1.0, 1.0] {
                        let (a, b, c) = (DVec3::X * sx, DVec3::Y * sy, DVec3::Z * sz);
                        grid.rasterize(a, b, c, |f| {
                            count[f.texel] += 1;
                            let d = grid.direction(f.texel);
                            let expect = 1.0 / (d.x.abs() + d.y.abs() + d.z.abs());
                            assert!((f.dist - expect).abs() < 1e-12, "n {n} texel {} {} vs {expect}", f.texel, f.dist);
                            let p = a * f.bary[0] + b * f.bary[1] + c * f.bary[2];
                            assert!((p - d * f.dist).length() < 1e-12);
                        });
                    }
                }
            }
            assert!(count.iter().all(|&c| c >= 1), "n {n}: hole");
        }
    }
}
