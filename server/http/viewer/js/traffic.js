// The robots' reservations on a map (TrafficService.ListReservations) at one moment: each
// robot a disc of its body's radius where its trajectory puts it then (at its start before it
// leaves, at its goal once it has arrived), its whole route a thin line. Two discs closer
// horizontally than their radii plus the pair's separation, with their bodies overlapping in
// height, are marked as a conflict: the rule the server checks exactly (proto/README.md,
// "Fleets"), so a marked pair is a schedule to look into. A pair's separation is the larger of
// the two its reservations ask (Reservation.separation_m), as the server keeps it. A
// reservation the server replanned to let another robot pass first (Reservation.replanned_for)
// has its route dashed and its disc marked, so a robot that changed its way without its own
// request stands out; a robot that follows replans (and so may be replanned) has its disc
// outlined dashed.

const SVG_NS = 'http://www.w3.org/2000/svg';

function polynomial(c, t) {
  let value = 0;
  for (let k = c.length - 1; k >= 0; --k) value = value * t + c[k];
  return value;
}

function seconds(timestamp) {
  // Protobuf's JSON mapping writes a Timestamp as RFC 3339 text.
  return Date.parse(timestamp) / 1000;
}

// The trajectory's axes at time t from its start, held before the start and after the end.
function stateAt(trajectory, t) {
  const pieces = trajectory.pieces || [];
  let local = Math.min(Math.max(t, 0), trajectory.duration_s);
  for (let i = 0; i < pieces.length; ++i) {
    if (local <= pieces[i].duration_s || i === pieces.length - 1) {
      const u = Math.min(local, pieces[i].duration_s);
      return pieces[i].axes.map((axis) => polynomial(axis.coefficients, u));
    }
    local -= pieces[i].duration_s;
  }
  return [0, 0, 0];
}

// A disc's classes: the robot, whether it is in conflict, replanned, or follows replans.
function discClasses(robot, inConflict) {
  const classes = ['robot'];
  if (inConflict) classes.push('conflict');
  if (robot.replannedFor) classes.push('replanned');
  if (robot.followsReplans) classes.push('follows-replans');
  return classes.join(' ');
}

// What a disc's title adds about replanning: why the robot's way changed, or that it may.
function replanNote(robot) {
  if (robot.replannedFor) return `, replanned to let ${robot.replannedFor} pass first`;
  return robot.followsReplans ? ', follows replans' : '';
}

export class Traffic {
  // `listing`: a ListReservationsResponse.
  constructor(listing) {
    const serverSeparation = listing.separation_m || 0;
    this.robots = (listing.reservations || []).map((r) => ({
      id: r.robot_id,
      start: seconds(r.start_time),
      expiry: seconds(r.expiry_time),
      trajectory: r.trajectory,
      body: r.body,
      // The JSON API prints every field, but a listing made elsewhere may leave defaults out.
      followsReplans: Boolean(r.follows_replans),
      replannedFor: r.replanned_for || '',
      separation: r.separation_m ?? serverSeparation,
    }));
    this.from = Math.min(...this.robots.map((r) => r.start));
    this.until = Math.max(...this.robots.map((r) => Math.min(r.expiry, r.start + r.trajectory.duration_s + 5)));
  }

  // Each robot's reference point and vertical extent at absolute time `time` [s since 1970].
  positionsAt(time) {
    return this.robots.map((r) => {
      const p = stateAt(r.trajectory, time - r.start);
      const bottom = p[2] - r.body.reference_height_m;
      return {
        robot: r, x: p[0], y: p[1], z: p[2], bottom, top: bottom + (p.length > 3 ? p[3] : r.body.height_m),
      };
    });
  }

  // The pairs of robots in conflict at `time`, as index pairs into positionsAt's array.
  conflictsAt(positions) {
    const pairs = [];
    for (let i = 0; i < positions.length; ++i) {
      for (let j = i + 1; j < positions.length; ++j) {
        const a = positions[i];
        const b = positions[j];
        const separation = Math.max(a.robot.separation, b.robot.separation);
        const limit = a.robot.body.radius_m + b.robot.body.radius_m + separation;
        if (Math.hypot(a.x - b.x, a.y - b.y) < limit && a.top > b.bottom && b.top > a.bottom) {
          pairs.push([i, j]);
        }
      }
    }
    return pairs;
  }

  // Draws the routes and the discs at `time` into `group` (in world coordinates).
  draw(group, time) {
    group.replaceChildren();
    const positions = this.positionsAt(time);
    const inConflict = new Set(this.conflictsAt(positions).flat());
    group.dataset.conflicts = inConflict.size;
    for (const r of this.robots) {
      const points = [];
      const steps = Math.max(20, Math.ceil(r.trajectory.duration_s / 0.25));
      for (let k = 0; k <= steps; ++k) {
        const p = stateAt(r.trajectory, (r.trajectory.duration_s * k) / steps);
        points.push(`${p[0]},${p[1]}`);
      }
      const route = document.createElementNS(SVG_NS, 'polyline');
      route.setAttribute('class', r.replannedFor ? 'route replanned' : 'route');
      route.dataset.robotId = r.id;
      route.setAttribute('vector-effect', 'non-scaling-stroke');
      route.setAttribute('points', points.join(' '));
      group.appendChild(route);
    }
    positions.forEach((p, index) => {
      const disc = document.createElementNS(SVG_NS, 'circle');
      disc.setAttribute('class', discClasses(p.robot, inConflict.has(index)));
      disc.setAttribute('cx', p.x);
      disc.setAttribute('cy', p.y);
      disc.setAttribute('r', p.robot.body.radius_m);
      disc.setAttribute('vector-effect', 'non-scaling-stroke');
      disc.dataset.robotId = p.robot.id;
      if (p.robot.replannedFor) disc.dataset.replannedFor = p.robot.replannedFor;
      const title = document.createElementNS(SVG_NS, 'title');
      title.textContent = `${p.robot.id} (${p.x.toFixed(2)}, ${p.y.toFixed(2)}, ${p.z.toFixed(2)}) m`
        + replanNote(p.robot);
      disc.appendChild(title);
      group.appendChild(disc);
    });
  }
}
