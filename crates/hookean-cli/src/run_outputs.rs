//! The outputs of one `hookean run` of a mass-spring scene as the run
//! writes them step by step (steps.csv, the OBJ frames and the frames kept
//! for view.html, the tutorial particle's trace, the progress bar), and
//! their bookkeeping in a checkpoint: what `--resume` needs to continue
//! writing them as the uninterrupted run would have.

use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use hookean::sinks::{ObjFrames, StepsCsv};
use hookean::{HookeanError, RunSummary, Simulation, Sink, StateRecord};
use hookean_ode::StepReport;

use crate::CliError;
use crate::run::{Frames, ParticleTrace, Progress};
use crate::thin::Thinned;
use crate::view::{FrameEnergies, ViewFrame};

/// What a run writes after every step.
pub(crate) struct Outputs {
    pub csv: StepsCsv<BufWriter<File>>,
    pub progress: Progress,
    pub trace: Option<ParticleTrace>,
    pub frames: Option<Frames>,
}

impl Outputs {
    /// Before the first step (of this process): a frame if one is due.
    pub fn start(&mut self, sim: &Simulation) -> Result<(), HookeanError> {
        match &mut self.frames {
            Some(f) => f.start(sim),
            None => Ok(()),
        }
    }

    /// After an accepted step: every output, in this order.
    pub fn step(&mut self, sim: &Simulation, r: &StepReport) -> Result<(), HookeanError> {
        self.csv.step(sim, r)?;
        self.progress.update(sim, r);
        if let Some(t) = &mut self.trace {
            t.step(sim, r)?;
        }
        if let Some(f) = &mut self.frames {
            f.step(sim, r)?;
        }
        Ok(())
    }

    /// At the end (or a stop): steps.csv flushed, the bar removed.
    pub fn finish(&mut self, sim: &Simulation, summary: &RunSummary) -> Result<(), HookeanError> {
        self.csv.finish(sim, summary)?;
        self.progress.clear();
        Ok(())
    }

    /// Adds the outputs' bookkeeping to a checkpoint (steps.csv is
    /// flushed first, and its length recorded).
    pub fn save(&mut self, record: &mut StateRecord) -> Result<(), HookeanError> {
        record.put_scalar("out.csv_len", self.csv.flushed_len()? as f64);
        match &self.frames {
            Some(f) => {
                record.put_scalar("out.frames.next", f.obj.next_due());
                record.put("out.frames.times", f.obj.times());
                let counters = f.view.counters().map(|c| c as f64);
                record.put("out.view.counters", &counters);
                let mut flat = Vec::new();
                for v in f.view.items() {
                    let e = v.energies.as_ref();
                    flat.push(v.t);
                    flat.push(f64::from(u8::from(e.is_some())));
                    flat.extend(e.map_or([0.0; 3], |e| [e.kinetic, e.gravitational, e.spring]));
                    flat.extend(&v.x);
                    flat.extend(&v.speed);
                }
                record.put("out.view.frames", &flat);
            }
            None => record.put("out.frames.times", &[]),
        }
        if let Some(t) = &self.trace {
            let counters = t.points.counters().map(|c| c as f64);
            record.put("out.trace.counters", &counters);
            let flat: Vec<f64> = t
                .points
                .items()
                .iter()
                .flat_map(|p| [p.0, p.1, p.2])
                .collect();
            record.put("out.trace.points", &flat);
        }
        Ok(())
    }

    /// The outputs of a run in `out` resumed from `record`, for a model of
    /// `n` particles (steps.csv is resumed by its caller): the frames after
    /// the checkpoint removed, the kept frames and trace restored.
    pub fn resume(
        mut self,
        record: &StateRecord,
        out: &Path,
        frame_rate: f64,
        n: usize,
        file: &Path,
    ) -> Result<Self, CliError> {
        let bad = |why: String| CliError::Input(format!("--resume {}: {why}", file.display()));
        let misfit = |e: hookean_ode::OdeError| bad(e.to_string());
        let counters = |name: &str| -> Result<[usize; 3], CliError> {
            let c = record.get_len(name, 3).map_err(misfit)?;
            let ok = c.iter().all(|v| *v >= 0.0 && v.fract() == 0.0 && *v < 1e15);
            ok.then(|| [c[0] as usize, c[1] as usize, c[2] as usize])
                .ok_or_else(|| bad(format!("entry `{name}` is malformed")))
        };
        if let Some(f) = &mut self.frames {
            let width = 5 + 4 * n;
            let flat = record.get("out.view.frames").map_err(misfit)?;
            if !flat.len().is_multiple_of(width) {
                return Err(bad("entry `out.view.frames` does not fit this model".into()));
            }
            let items = flat
                .chunks_exact(width)
                .map(|c| ViewFrame {
                    t: c[0],
                    energies: (c[1] == 1.0).then_some(FrameEnergies {
                        kinetic: c[2],
                        gravitational: c[3],
                        spring: c[4],
                    }),
                    x: c[5..5 + 3 * n].to_vec(),
                    speed: c[5 + 3 * n..].to_vec(),
                })
                .collect();
            f.view = Thinned::restored(items, counters("out.view.counters")?)
                .ok_or_else(|| bad("entry `out.view.counters` is malformed".into()))?;
            let next = record.scalar("out.frames.next").map_err(misfit)?;
            let times = record.get("out.frames.times").map_err(misfit)?.to_vec();
            f.obj = ObjFrames::resume(out, frame_rate, next, times)
                .map_err(|e| CliError::Failed(e.to_string()))?;
        }
        if let Some(t) = &mut self.trace {
            let flat = record.get("out.trace.points").map_err(misfit)?;
            if !flat.len().is_multiple_of(3) {
                return Err(bad("entry `out.trace.points` is malformed".into()));
            }
            let items = flat.chunks_exact(3).map(|p| (p[0], p[1], p[2])).collect();
            t.points = Thinned::restored(items, counters("out.trace.counters")?)
                .ok_or_else(|| bad("entry `out.trace.counters` is malformed".into()))?;
        }
        Ok(self)
    }
}
