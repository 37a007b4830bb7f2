//! The per-point query does not allocate: a counting global allocator around many
//! `accumulate_log_visibility` / `shade_point` calls, and a rebuild of a cluster of the same size.
//! The counter (`counting_alloc`) is per thread: the harness's own threads allocate meanwhile.

use spherebake_runtime::shadow::{accumulate_log_visibility, uniform_light, ClusterBlockers, ExpMethod, ShadowContext};
use spherebake_runtime::Sphere;

mod counting_alloc;
use counting_alloc::allocs;

#[test]
fn per_point_queries_do_not_allocate() {
    let leaves: Vec<Sphere> = (0..40)
        .map(|i| {
            let a = i as f32 * 0.7;
            Sphere {
                center: [a.cos() * 2.0, 0.5 + (i % 5) as f32 * 0.3, a.sin() * 2.0],
                radius: 0.2 + (i % 3) as f32 * 0.1,
            }
        })
        .collect();
    let ctx = ShadowContext::new(4, ExpMethod::default()).unwrap();
    let mut light = [0.0; 16];
    uniform_light(4, &mut light);
    let mut t = [0.0; 16];
    ctx.shading_vector(&light, [0.0, 1.0, 0.0], &mut t).unwrap();
    let mut cb = ClusterBlockers::new();
    let fresh = allocs();
    cb.build(4, &leaves, None, [0.0; 3], 0.5, 0.4363323).unwrap();
    // The zero count below means something: the first build grows its buffers, and that is seen.
    assert!(allocs() > fresh, "a first build into fresh buffers allocates");
    let before = allocs();
    let mut sum = 0.0;
    for k in 0..200 {
        let p = [(k % 20) as f32 * 0.05 - 0.5, 0.0, (k / 20) as f32 * 0.05 - 0.25];
        sum += ctx.shade_point(&cb, p, [0.0, 1.0, 0.0], &t).unwrap();
        let mut log = [0.0f32; 16];
        accumulate_log_visibility(cb.blockers(), 4, p, Some([0.0, 1.0, 0.0]), &mut log).unwrap();
    }
    // Same cluster size again: the buffers are reused.
    cb.build(4, &leaves, None, [0.1, 0.0, 0.0], 0.5, 0.4363323).unwrap();
    let s = cb.correct_overlap(&ctx, [0.1, 0.0, 0.0], [0.0, 1.0, 0.0], 256).unwrap();
    assert!(s > 0.0 && s <= 1.0);
    let after = allocs();
    assert_eq!(after, before, "allocations during per-point queries");
    assert!(sum.is_finite() && sum > 0.0);
}
