//! The run's configuration, as an INS decides it: at start the board is in standby and waits
//! for the host's configuration frame for a bounded window (`board::STANDBY_US`); an accepted
//! frame's run configuration becomes the run's, and with none in the window the board's
//! compiled-in one does (the qemu board's: its command line), flagged to the host
//! ([`RunSource::Default`]: the status flag `DEFAULT_CONFIG`). Once decided it stays for the
//! run: a later frame may change the output rates only; another run configuration is refused
//! ([`ConfigRefusal::RunInProgress`]). A frame's mounting is the installation's: the run's
//! samples are turned from the driver's mounting to it ([`RunState::remount`]).

use hal_adapters::drivers::Mounting;
use hal_adapters::protocol::config::{BoardIdentity, ConfigRefusal, DeviceConfig};
use hal_adapters::protocol::status::RunSource;
use nav_core::navigator::RunConfig;

/// The run's configuration: the board's compiled-in one, what the board is, and the run's once
/// decided.
pub struct RunState {
    default: RunConfig,
    identity: BoardIdentity,
    running: Option<(RunConfig, RunSource)>,
    /// The run's mounting (the board's until a frame gives one).
    mounting: Mounting,
    /// From the driver's axes to the run's mounting; `None` when they are the same.
    remount: Option<Mounting>,
}

impl RunState {
    /// In standby, with the board's compiled-in run `default` (already validated at the IMU's
    /// rate) and what the board is (`identity`).
    pub fn new(default: RunConfig, identity: BoardIdentity) -> Self {
        Self {
            default,
            mounting: identity.mounting,
            identity,
            running: None,
            remount: None,
        }
    }

    /// What the board is.
    pub fn identity(&self) -> &BoardIdentity {
        &self.identity
    }

    /// The run's configuration and where it came from, once decided.
    pub fn running(&self) -> Option<&(RunConfig, RunSource)> {
        self.running.as_ref()
    }

    /// The rotation that turns the driver's samples into the run's body axes, when the run's
    /// mounting (a frame's) is not the one the driver applies ([`Mounting::relative_to`]).
    pub fn remount(&self) -> Option<&Mounting> {
        self.remount.as_ref()
    }

    /// Where the run's configuration comes from ([`RunSource::Waiting`] in standby).
    pub fn source(&self) -> RunSource {
        self.running
            .map_or(RunSource::Waiting, |(_, source)| source)
    }

    /// Takes a configuration frame: checked ([`DeviceConfig::check_on`]: its values, the
    /// board, the run in progress); in standby an accepted frame's run configuration (with the
    /// board's calibration) and mounting become the run's. `Ok(true)` when they did.
    pub fn take(&mut self, config: &DeviceConfig) -> Result<bool, ConfigRefusal> {
        let running = self.running.as_ref().map(|(run, _)| (run, &self.mounting));
        config.check_on(&self.identity, running)?;
        if self.running.is_some() {
            return Ok(false);
        }
        let run = config.run_with(self.default.calibration);
        self.running = Some((run, RunSource::Host));
        self.mounting = config.mounting;
        self.remount = (config.mounting != self.identity.mounting)
            .then(|| config.mounting.relative_to(&self.identity.mounting));
        Ok(true)
    }

    /// The standby window ended without an accepted frame: the compiled-in configuration runs.
    pub fn use_default(&mut self) {
        self.running
            .get_or_insert((self.default, RunSource::Default));
    }
}
