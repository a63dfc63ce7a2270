// What the signed-in role and a scan's state allow: the UI hides, goniod enforces.

// What a role may do; the server enforces the same (the method table), the UI only hides.
const rank = { none: 0, viewer: 1, technician: 2, admin: 3 };
export function can(role, action) {
  const need = { control: 'technician', submit: 'technician', ack: 'technician', predict: 'technician', create: 'technician', fit: 'technician', calibrate: 'admin' }[action] || 'viewer';
  return (rank[role] || 0) >= rank[need];
}

// Which actions a scan in a state offers (scan.pause/resume/cancel and queue.reorder).
export function scanActions(state) {
  switch (state) {
    case 'queued': return ['cancel', 'reorder'];
    case 'running': return ['pause', 'cancel'];
    case 'paused':
    case 'interrupted': return ['resume', 'cancel'];
    default: return [];
  }
}
