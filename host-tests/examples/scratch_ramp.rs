use host_tests::aided::{self, AidedSink};
use host_tests::aided_bench::{prepare, state_error};
use host_tests::gnss_bench::{
    outlier_case, outlier_case_code_receiver, outlier_case_with_velocity,
};
use host_tests::report::interpolate;
use host_tests::sensor_model::Grade;
use nav_core::ins_filter::AidedIns;
struct P<'a> {
    truth: &'a [host_tests::truth::Truth],
    from: f64,
    to: f64,
}
impl AidedSink<f64> for P<'_> {
    fn sample(&mut self, _t: u64, _ins: &AidedIns<f64>) -> anyhow::Result<()> {
        Ok(())
    }
    fn updated(&mut self, t_us: u64, ins: &AidedIns<f64>) {
        let t = t_us as f64 * 1e-6;
        if t < self.from || t > self.to {
            return;
        }
        let tr = interpolate(self.truth, t).unwrap();
        let e = state_error(ins.state(), &tr);
        let p = ins.position_covariance();
        let c = ins.counters().position;
        println!(
            "{t:.1} err {:.2} {:.2} sig {:.2} {:.2} v {:.3} {:.3} {:?} acc {} rej {} cons {} win {} clu {}",
            e[0],
            e[1],
            p[(0, 0)].sqrt(),
            p[(1, 1)].sqrt(),
            e[3],
            e[4],
            ins.status(),
            c.accepted,
            c.rejected,
            c.consecutive_rejected,
            c.window_rejected,
            c.cluster_rejected
        );
    }
}
fn main() {
    let a: Vec<String> = std::env::args().collect();
    let seed: u64 = a[1].parse().unwrap();
    let grade = if a[2] == "fog" {
        Grade::Fog
    } else {
        Grade::MemsTactical
    };
    let case = match a[2].as_str() {
        "code" => outlier_case_code_receiver(grade, seed),
        "vel" => outlier_case_with_velocity(grade, seed),
        _ => outlier_case(grade, seed),
    };
    let prepared = prepare(&case).unwrap();
    let mut sink = P {
        truth: &prepared.sim.truth,
        from: a[3].parse().unwrap(),
        to: a[4].parse().unwrap(),
    };
    aided::run(
        prepared.samples(),
        &prepared.gnss.fixes,
        prepared.seq.clone(),
        &mut sink,
    )
    .unwrap();
}
