use host_tests::align_bench::seed003::*;
use nav_core::alignment::fine::FineAlignment;
use nav_core::{ImuIncrement, Scalar};

fn feed<T: Scalar>(rec: &Recorded, f: &mut FineAlignment<T>, from: usize, to: usize) {
    for inc in &rec.increments[from..to] {
        f.add(&ImuIncrement {
            delta_theta_ib_b: inc.delta_theta_ib_b.map(T::c),
            delta_v_ib_b: inc.delta_v_ib_b.map(T::c),
            dt: T::c(inc.dt),
        })
        .unwrap();
    }
}

#[test]
fn explore() {
    let rec = auv_bench(40.0).unwrap();
    let model = fog_noise_only();
    let config = matched_config(&model, 0.0, 0.0);
    let init = initial_error(0);
    let mut a = FineAlignment::<f64>::new(
        coarse(&rec.q_start, &init, &initial_sigma()),
        rec.position,
        fine_config_in(&config),
    );
    let mut b = FineAlignment::<f32>::new(
        coarse(&rec.q_start, &init, &initial_sigma()),
        rec.position,
        fine_config_in(&config),
    );
    let mut k = 0;
    for t in [0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 30.0] {
        let kk = (t * 400.0) as usize;
        feed(&rec, &mut a, k, kk);
        feed(&rec, &mut b, k, kk);
        k = kk;
        let pa = a.covariance();
        let pb = b.covariance();
        print!("{t:5}: ");
        for i in 0..15 {
            print!("{:+.1e} ", (pb[(i, i)] as f64 - pa[(i, i)]) / pa[(i, i)]);
        }
        println!(" P_DD {:e}", pa[(8, 8)]);
    }
}
